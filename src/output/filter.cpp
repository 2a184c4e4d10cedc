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

bool RecordFilter::matches(const Record& r, Nanos first) const {
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
        // Untimed records cannot be placed in a time range.
        if (!has_time(r.frame.start)) return false;
        const Nanos relative_base = has_time(first) ? first : r.frame.start;
        if (from && r.frame.start < (from_relative ? relative_base + *from : *from)) return false;
        if (to && r.frame.start > (to_relative ? relative_base + *to : *to)) return false;
    }
    return true;
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

Result<std::pair<Nanos, bool>> parse_time_bound(std::string_view text) {
    const bool relative = text.starts_with('+');
    if (relative) text.remove_prefix(1);
    double seconds = 0;
    const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), seconds);
    if (text.empty() || ec != std::errc{} || ptr != text.data() + text.size() ||
        !std::isfinite(seconds) || seconds < 0) {
        return Error{
            fmt::format("bad time \"{}\" (seconds as in the CSV time column, or +S "
                        "after the first frame)",
                        text)};
    }
    return std::pair(static_cast<Nanos>(std::llround(seconds * 1e9)), relative);
}

namespace {

class FilterSink final : public RecordSink {
  public:
    FilterSink(RecordFilter filter, std::unique_ptr<RecordSink> inner)
        : filter_(std::move(filter)), inner_(std::move(inner)) {}
    void begin(const SessionInfo& s) override { inner_->begin(s); }
    void record(const Record& r) override {
        if (!has_time(first_) && has_time(r.frame.start)) first_ = r.frame.start;
        if (filter_.matches(r, first_)) inner_->record(r);
    }
    void end(const Totals& t, const std::vector<std::string>& remarks) override {
        inner_->end(t, remarks);
    }
    void flush() override { inner_->flush(); }

  private:
    RecordFilter filter_;
    std::unique_ptr<RecordSink> inner_;
    Nanos first_ = kNoTime;
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
