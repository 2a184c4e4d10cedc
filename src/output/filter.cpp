#include "output/filter.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>

#include "output/sinks.hpp"

namespace rtuscope {

bool RecordFilter::empty() const {
    return slaves.empty() && functions.empty() && kinds.empty() && !from && !to;
}

namespace {

bool in_ranges(const RecordFilter::Ranges& ranges, unsigned value) {
    return std::any_of(ranges.begin(), ranges.end(),
                       [&](const auto& r) { return value >= r.first && value <= r.second; });
}

bool flagged(const Record& r) {
    return !r.notes.empty() || std::any_of(r.values.begin(), r.values.end(),
                                           [](const auto& v) { return !v.notes.empty(); });
}

}  // namespace

bool RecordFilter::matches(const Record& r, std::optional<Nanos> from_at,
                           std::optional<Nanos> to_at) const {
    const bool framed = r.kind != Kind::noise && !r.frame.bytes.empty();
    if (!slaves.empty() && !(framed && in_ranges(slaves, r.frame.slave()))) return false;
    if (!functions.empty() && !(framed && r.frame.bytes.size() >= 2 &&
                                in_ranges(functions, r.frame.function() & 0x7FU))) {
        return false;
    }
    if (!kinds.empty()) {
        const bool kind_listed =
            std::find(kinds.begin(), kinds.end(), to_string(r.kind)) != kinds.end();
        const bool flag_listed =
            std::find(kinds.begin(), kinds.end(), "flagged") != kinds.end() && flagged(r);
        if (!kind_listed && !flag_listed) return false;
    }
    if (from || to) {
        // Untimed records cannot be placed in a time range, nor records in a range that
        // the input's times do not have.
        if (!has_time(r.frame.start)) return false;
        if ((from && !from_at) || (to && !to_at)) return false;
        if (from && r.frame.start < *from_at) return false;
        if (to && r.frame.start > *to_at) return false;
    }
    return true;
}

std::optional<Nanos> TimeBound::place(TimeBase base, Nanos first) const {
    switch (kind) {
        case Kind::seconds:
            return nanos;
        case Kind::after_first:
            return has_time(first) ? std::optional(first + nanos) : std::nullopt;
        case Kind::time_of_day:
        case Kind::date_time:
            break;
    }
    if (!check_time_bound(*this, base) || !has_time(first)) return std::nullopt;
    if (base == TimeBase::unix_time) {
        // Local time, as the text shows it.
        const std::int64_t first_second = floor_div(first, kNanosPerSecond);
        const LocalTime first_local = local_time(first_second);
        CivilDate day = date;
        std::int64_t second = nanos / kNanosPerSecond;
        if (kind == Kind::time_of_day) {
            day = first_local.date;
            const Nanos first_of_day = first_local.second_of_day * kNanosPerSecond +
                                       (first - first_second * kNanosPerSecond);
            if (nanos < first_of_day) second += 86'400;  // the next day (mktime carries it)
        }
        const std::optional<std::int64_t> at = unix_from_local(day, second);
        if (!at || *at > kMaxTime / kNanosPerSecond || *at < -kMaxTime / kNanosPerSecond) {
            return std::nullopt;
        }
        return *at * kNanosPerSecond + nanos % kNanosPerSecond;
    }
    // As read: a date and time counted as if UTC, or a log's day and time of day.
    if (kind == Kind::date_time) {
        return days_from_civil(date.year, date.month, date.day) * kNanosPerDay + nanos;
    }
    const std::int64_t first_day = floor_div(first, kNanosPerDay);
    const Nanos first_of_day = first - first_day * kNanosPerDay;
    return (first_day + (nanos < first_of_day ? 1 : 0)) * kNanosPerDay + nanos;
}

Status check_time_bound(const TimeBound& bound, TimeBase base) {
    const bool clock =
        bound.kind == TimeBound::Kind::time_of_day || bound.kind == TimeBound::Kind::date_time;
    if (clock && base == TimeBase::relative) {
        return Error{
            "the input's times are relative seconds, with no clock: give seconds as in the "
            "CSV time column, or +S after the first frame"};
    }
    if (bound.kind == TimeBound::Kind::date_time && base == TimeBase::time_of_day) {
        return Error{"the input's times have no date: give a time of day (08:00:01)"};
    }
    return ok_status();
}

Result<RecordFilter::Ranges> parse_ranges(std::string_view text, unsigned max) {
    RecordFilter::Ranges ranges;
    auto number = [&](std::string_view s) -> std::optional<unsigned> {
        int base = 10;
        if (s.starts_with("0x") || s.starts_with("0X")) {
            s.remove_prefix(2);
            base = 16;
        }
        unsigned v = 0;
        const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v, base);
        if (s.empty() || ec != std::errc{} || ptr != s.data() + s.size() || v > max) {
            return std::nullopt;
        }
        return v;
    };
    while (!text.empty()) {
        const auto comma = text.find(',');
        const std::string_view item = text.substr(0, comma);
        const auto dash = item.find('-');
        const auto lo = number(item.substr(0, dash));
        const auto hi = dash == std::string_view::npos ? lo : number(item.substr(dash + 1));
        if (!lo || !hi || *lo > *hi) {
            return Error{
                fmt::format("bad list \"{}\" (e.g. 1,3,10-20 or 0x10; at most {})", text, max)};
        }
        ranges.emplace_back(*lo, *hi);
        if (comma == std::string_view::npos) break;
        text.remove_prefix(comma + 1);
    }
    if (ranges.empty()) return Error{"empty list"};
    return ranges;
}

Result<std::vector<std::string>> parse_kinds(std::string_view text) {
    static const std::vector<std::string_view> known = {
        "request", "response", "exception", "broadcast", "unknown", "invalid", "noise", "flagged"};
    std::vector<std::string> kinds;
    while (true) {
        const auto comma = text.find(',');
        const std::string_view item = text.substr(0, comma);
        if (std::find(known.begin(), known.end(), item) == known.end()) {
            return Error{
                fmt::format("unknown kind \"{}\" (request, response, exception, "
                            "broadcast, unknown, invalid, noise, flagged)",
                            item)};
        }
        kinds.emplace_back(item);
        if (comma == std::string_view::npos) break;
        text.remove_prefix(comma + 1);
    }
    return kinds;
}

namespace {

// "HH:MM:SS[.frac]" from the start of `text`: nanoseconds since midnight; false if it is
// not one (or more than 9 fractional digits).
bool parse_clock(std::string_view text, Nanos& out) {
    auto two_digits = [&](std::size_t at, unsigned& value) {
        if (at + 2 > text.size() || text[at] < '0' || text[at] > '9' || text[at + 1] < '0' ||
            text[at + 1] > '9') {
            return false;
        }
        value = static_cast<unsigned>((text[at] - '0') * 10 + (text[at + 1] - '0'));
        return true;
    };
    unsigned h = 0;
    unsigned m = 0;
    unsigned s = 0;
    if (!two_digits(0, h) || text.size() < 8 || text[2] != ':' || !two_digits(3, m) ||
        text[5] != ':' || !two_digits(6, s) || h > 23 || m > 59 || s > 59) {
        return false;
    }
    Nanos fraction = 0;
    if (text.size() > 8) {
        if (text[8] != '.' || text.size() == 9 || text.size() > 18) return false;
        Nanos scale = kNanosPerSecond;
        for (const char c : text.substr(9)) {
            if (c < '0' || c > '9') return false;
            scale /= 10;
            fraction += (c - '0') * scale;
        }
    }
    out = ((static_cast<Nanos>(h) * 60 + m) * 60 + s) * kNanosPerSecond + fraction;
    return true;
}

// "YYYY-MM-DD" at the start of `text`, a real date from 1900 to 2111 (the times
// rtuscope decodes, time.hpp).
bool parse_date(std::string_view text, CivilDate& out) {
    if (text.size() != 10 || text[4] != '-' || text[7] != '-') return false;
    unsigned y = 0;
    const auto [ptr, ec] = std::from_chars(text.data(), text.data() + 4, y);
    if (ec != std::errc{} || ptr != text.data() + 4) return false;
    for (const std::size_t at : {5U, 6U, 8U, 9U}) {
        if (text[at] < '0' || text[at] > '9') return false;
    }
    const auto mo = static_cast<unsigned>((text[5] - '0') * 10 + (text[6] - '0'));
    const auto d = static_cast<unsigned>((text[8] - '0') * 10 + (text[9] - '0'));
    if (y < 1900 || y > 2111 || mo < 1 || mo > 12 || d < 1) return false;
    // The day must exist: 2026-02-30 would come back as 2026-03-02.
    const CivilDate back = civil_from_days(days_from_civil(y, mo, d));
    if (back.month != mo || back.day != d) return false;
    out = {y, mo, d};
    return true;
}

}  // namespace

Result<TimeBound> parse_time_bound(std::string_view text) {
    const std::string_view given = text;
    const auto bad = [&] {
        return Error{
            fmt::format("bad time \"{}\" (a time of day 08:00:01.5, a date and time "
                        "2026-11-21 08:00:01, seconds as in the CSV time column, or +S after "
                        "the first frame)",
                        given)};
    };
    TimeBound bound;
    if (text.size() >= 19 && (text[10] == ' ' || text[10] == 'T')) {
        bound.kind = TimeBound::Kind::date_time;
        if (!parse_date(text.substr(0, 10), bound.date) ||
            !parse_clock(text.substr(11), bound.nanos)) {
            return bad();
        }
        return bound;
    }
    if (text.find(':') != std::string_view::npos) {
        bound.kind = TimeBound::Kind::time_of_day;
        if (!parse_clock(text, bound.nanos)) return bad();
        return bound;
    }
    if (text.starts_with('+')) {
        bound.kind = TimeBound::Kind::after_first;
        text.remove_prefix(1);
    }
    double seconds = 0;
    const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), seconds);
    if (text.empty() || ec != std::errc{} || ptr != text.data() + text.size() ||
        !std::isfinite(seconds) || seconds < 0 || seconds > 4.5e9) {  // kMaxTime
        return bad();
    }
    bound.nanos = static_cast<Nanos>(std::llround(seconds * 1e9));
    return bound;
}

namespace {

class FilterSink final : public RecordSink {
  public:
    FilterSink(RecordFilter filter, std::unique_ptr<RecordSink> inner)
        : filter_(std::move(filter)), inner_(std::move(inner)) {}
    void begin(const SessionInfo& s) override {
        base_ = s.source.time_base;
        inner_->begin(s);
    }
    void record(const Record& r) override {
        if (!placed_ && has_time(r.frame.start)) {
            // The bounds are placed once, on the first timed record.
            placed_ = true;
            if (filter_.from) from_at_ = filter_.from->place(base_, r.frame.start);
            if (filter_.to) to_at_ = filter_.to->place(base_, r.frame.start);
        }
        if (filter_.matches(r, from_at_, to_at_)) inner_->record(r);
    }
    void end(const Totals& t, const std::vector<std::string>& remarks) override {
        inner_->end(t, remarks);
    }
    void flush() override { inner_->flush(); }
    void idle(Nanos now) override { inner_->idle(now); }

  private:
    RecordFilter filter_;
    std::unique_ptr<RecordSink> inner_;
    TimeBase base_ = TimeBase::none;
    bool placed_ = false;
    std::optional<Nanos> from_at_;
    std::optional<Nanos> to_at_;
};

class TeeSink final : public RecordSink {
  public:
    explicit TeeSink(std::vector<std::unique_ptr<RecordSink>> sinks) : sinks_(std::move(sinks)) {}
    void begin(const SessionInfo& s) override {
        for (auto& sink : sinks_) sink->begin(s);
    }
    void record(const Record& r) override {
        for (auto& sink : sinks_) sink->record(r);
    }
    void end(const Totals& t, const std::vector<std::string>& remarks) override {
        for (auto& sink : sinks_) sink->end(t, remarks);
    }
    void flush() override {
        for (auto& sink : sinks_) sink->flush();
    }
    void idle(Nanos now) override {
        for (auto& sink : sinks_) sink->idle(now);
    }

  private:
    std::vector<std::unique_ptr<RecordSink>> sinks_;
};

}  // namespace

std::unique_ptr<RecordSink> make_filter_sink(RecordFilter filter,
                                             std::unique_ptr<RecordSink> inner) {
    return std::make_unique<FilterSink>(std::move(filter), std::move(inner));
}

std::unique_ptr<RecordSink> make_tee_sink(std::vector<std::unique_ptr<RecordSink>> sinks) {
    return std::make_unique<TeeSink>(std::move(sinks));
}

}  // namespace rtuscope
