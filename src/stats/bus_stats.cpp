// Counting records per slave/function and per poll, within the bounds of bus_stats.hpp.
#include "stats/bus_stats.hpp"

#include <algorithm>
#include <bit>
#include <string_view>

namespace rtuscope {
void add_function_counts(FunctionStats& into, const FunctionStats& from) {
    into.requests += from.requests;
    into.answers += from.answers;
    into.exceptions += from.exceptions;
    into.broken += from.broken;
    for (const auto& [code, n] : from.exception_codes) into.exception_codes[code] += n;
    into.crc_errors += from.crc_errors;
    into.no_answer += from.no_answer;
    into.broadcasts += from.broadcasts;
    into.unsolicited += from.unsolicited;
}

void merge_function_stats(FunctionStats& into, const FunctionStats& from) {
    add_function_counts(into, from);
    into.turnarounds.merge(from.turnarounds);
}

void BusStats::add(const Record& record) {
    const Frame& f = record.frame;
    bus_.bytes += f.bytes.size();
    if (f.transport == Transport::tcp) bus_.tcp_bytes += f.bytes.size();
    if (has_time(f.start) && (!has_time(bus_.first_start) || f.start < bus_.first_start)) {
        bus_.first_start = f.start;
    }
    if (has_time(f.end) && (!has_time(bus_.last_end) || f.end > bus_.last_end)) {
        bus_.last_end = f.end;
    }
    // What a stop or a capture's snap length cut short was on the line, but is no fault
    // of the bus's.
    if (record.notes.has(note_id::cut_by_stop)) return;
    if (record.notes.has(note_id::cut_by_snaplen)) {
        count_cut_answer(record);
        return;
    }
    if (record.kind == Kind::noise) {
        ++bus_.noise_runs;
        bus_.noise_bytes += f.bytes.size();
        return;
    }
    ++bus_.frames;
    if (record.kind == Kind::invalid) ++bus_.invalid;
    if (record.kind == Kind::unknown) ++bus_.unknown;

    // A frame cut short before its function code has no row to go to.
    if (f.bytes.size() < 2) return;
    const Key key{f.slave(), static_cast<std::uint8_t>(f.function() & 0x7FU)};
    const bool crc_error = f.crc.status == CrcStatus::bad || f.crc.status == CrcStatus::swapped;
    const bool invalid = record.kind == Kind::invalid;
    // What the pairing took for a request awaiting an answer or for an answer, broken ones
    // included. A request still waiting when the run stopped has no outcome yet: it is not
    // counted.
    const bool request =
        record.awaits_answer && !record.notes.has(note_id::stopped_before_answer);
    const bool answer = record.kind == Kind::response || record.kind == Kind::exception ||
                        (invalid && record.request_number != 0);
    // Rows only for what has a column: an unknown frame alone would be an empty row.
    if (!crc_error && !request && !answer && record.kind != Kind::broadcast &&
        record.kind != Kind::request) {
        return;
    }
    FunctionStats& s = functions_[key];
    if (s.function == nullptr) s.function = record.decoded.function;
    if (crc_error) ++s.crc_errors;
    if (record.kind == Kind::broadcast) ++s.broadcasts;
    if (request) {
        ++s.requests;
        if (record.went_unanswered()) ++s.no_answer;
    }
    if (record.kind == Kind::request) count_poll(key, record);
    if (answer) count_answer(s, record);
}

void BusStats::count_poll(const Key& key, const Record& record) {
    const Frame& f = record.frame;
    PollKey poll{key.first, key.second, {}, 0};
    const std::size_t data = f.bytes.size() >= 4 ? f.bytes.size() - 4 : 0;
    poll.size = static_cast<std::uint8_t>(std::min<std::size_t>(data, 4));
    std::copy_n(f.bytes.begin() + 2, poll.size, poll.data.begin());
    PollStats& p = poll_of(poll);
    ++p.requests;
    if (has_time(f.start)) {
        if (has_time(p.last_start)) add_duration(p.cycles, f.start - p.last_start);
        p.last_start = f.start;
    }
}

void BusStats::count_cut_answer(const Record& record) {
    // The bus answered, the capture kept the start of it: its request has its outcome, an
    // answer or an exception by the function code, neither broken nor missing.
    const Frame& f = record.frame;
    if (record.request_number == 0 || f.bytes.size() < 2 ||
        record.notes.has(note_id::duplicate_answer)) {
        return;
    }
    FunctionStats& s = functions_[{f.slave(), static_cast<std::uint8_t>(f.function() & 0x7FU)}];
    if (s.function == nullptr) s.function = record.decoded.function;
    if ((f.function() & 0x80U) != 0) {
        ++s.exceptions;
        if (f.bytes.size() >= 3) count_exception_code(s, f.bytes[2]);
    } else {
        ++s.answers;
    }
    if (has_time(record.latency)) add_duration(s.turnarounds, record.latency);
}

void BusStats::count_answer(FunctionStats& s, const Record& record) {
    const Frame& f = record.frame;
    if (record.kind == Kind::exception && f.bytes.size() >= 3) count_exception_code(s, f.bytes[2]);
    if (record.answers_no_request()) {
        ++s.unsolicited;
        return;
    }
    switch (record.kind) {
        case Kind::response:
            ++s.answers;
            break;
        case Kind::exception:
            ++s.exceptions;
            break;
        default:
            ++s.broken;
            break;
    }
    if (has_time(record.latency)) add_duration(s.turnarounds, record.latency);
}

void BusStats::finish() {
    all_ = {};
    for (auto& [key, s] : functions_) {
        s.turnarounds.finish();
        merge_function_stats(all_, s);
    }
    for (auto& [key, p] : polls_) p.cycles.finish();
}

PollStats& BusStats::poll_of(const PollKey& key) {
    ++requests_;
    if (auto it = polls_.find(key); it != polls_.end()) return it->second;
    if (polls_.size() >= kMaxPolls) forget_rare_polls();
    PollStats& poll = polls_[key];
    poll.first_request = requests_;
    return poll;
}

void BusStats::forget_rare_polls() {
    // A quarter at a time, so that the sweep is paid once per kMaxPolls / 4 new requests.
    using Entry = std::map<PollKey, PollStats>::iterator;
    auto rate = [this](Entry e) {
        const std::uint64_t age = std::max(requests_ - e->second.first_request + 1, kPollHorizon);
        return static_cast<double>(e->second.requests) / static_cast<double>(age);
    };
    std::vector<std::pair<double, Entry>> by_rate;
    by_rate.reserve(polls_.size());
    for (auto it = polls_.begin(); it != polls_.end(); ++it) by_rate.emplace_back(rate(it), it);
    const auto forgotten = std::next(by_rate.begin(), by_rate.size() / 4);
    // Equal rates go by key, so that the same input always keeps the same polls.
    std::nth_element(by_rate.begin(), forgotten, by_rate.end(), [](const auto& a, const auto& b) {
        return a.first != b.first ? a.first < b.first : a.second->first < b.second->first;
    });
    for (auto it = by_rate.begin(); it != forgotten; ++it) {
        forget_duration_set(it->second->second.cycles);
        polls_.erase(it->second);
    }
    forgotten_polls_ += by_rate.size() / 4;
    share_bins();
}

void BusStats::count_exception_code(FunctionStats& row, std::uint8_t code) {
    if (auto it = row.exception_codes.find(code); it != row.exception_codes.end()) {
        ++it->second;
    } else if (exception_codes_ < kMaxExceptionCodes) {
        row.exception_codes.emplace(code, 1);
        ++exception_codes_;
    } else {
        ++unlisted_exceptions_;
    }
}

void BusStats::add_duration(DurationCounts& counts, Nanos value) {
    if (counts.empty()) {
        ++few_value_sets_;
        share_bins();
        counts.limit(max_distinct_);
    }
    counts.add(value);
    if (counts.size() == kMinDistinct + 1) {
        --few_value_sets_;
        ++many_value_sets_;
        share_bins();
    }
}

void BusStats::forget_duration_set(const DurationCounts& counts) {
    if (counts.empty()) return;
    if (counts.size() <= kMinDistinct) {
        --few_value_sets_;
    } else {
        --many_value_sets_;
    }
}

void BusStats::share_bins() {
    // A set of at most kMinDistinct values holds no more bins than that whatever its share,
    // so the others share what those leave; in powers of two, so that the share changes a
    // few times, not with every new set (each change visits every set).
    const std::size_t left = kBinBudget - std::min(kBinBudget, kMinDistinct * few_value_sets_);
    const std::size_t share =
        std::clamp(std::bit_floor(left / std::max<std::size_t>(many_value_sets_, 1)), kMinDistinct,
                   DurationCounts::kMaxDistinct);
    if (share == max_distinct_) return;
    max_distinct_ = share;
    for (auto& [key, s] : functions_) {
        if (!s.turnarounds.empty()) s.turnarounds.limit(share);
    }
    for (auto& [key, p] : polls_) {
        if (!p.cycles.empty()) p.cycles.limit(share);
    }
}

bool BusStats::timed() const {
    return duration().has_value();
}

std::optional<Nanos> BusStats::duration() const {
    if (!has_time(bus_.first_start) || !has_time(bus_.last_end)) return std::nullopt;
    if (bus_.last_end <= bus_.first_start) return std::nullopt;
    return bus_.last_end - bus_.first_start;
}

std::optional<double> BusStats::utilisation() const {
    const std::optional<Nanos> d = duration();
    if (!d || bus_.bytes == bus_.tcp_bytes) return std::nullopt;
    return 100.0 * static_cast<double>(bus_.bytes - bus_.tcp_bytes) *
           static_cast<double>(session_.line.char_time()) / static_cast<double>(*d);
}

const std::pair<const PollKey, PollStats>* BusStats::main_poll(std::optional<Key> key) const {
    // The polls of one slave and function lie together in the map, from the key with
    // zero data on: a row reads its own, not every poll of the bus (a capture with many
    // distinct writes has hundreds of thousands, and the table asks once per row).
    auto it = key ? polls_.lower_bound(PollKey{key->first, key->second, {}, 0}) : polls_.begin();
    const std::pair<const PollKey, PollStats>* best = nullptr;
    for (; it != polls_.end(); ++it) {
        if (key && (it->first.slave != key->first || it->first.function != key->second)) break;
        if (best == nullptr || it->second.requests > best->second.requests) best = &*it;
    }
    return best;
}

}  // namespace rtuscope
