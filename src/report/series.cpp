#include "report/series.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>

namespace rtuscope::report {
namespace {

constexpr std::array<ErrorKindInfo, kErrorKinds> kErrorKindInfo{{
    {"crc", "bad CRC"},
    {"no_answer", "no answer"},
    {"exception", "exception"},
    {"unsolicited", "unsolicited"},
    {"noise", "noise"},
}};

// Which of the timeline's errors a record is; the same rules as the closing summary's
// counts (pipeline.cpp count_record).
std::array<bool, kErrorKinds> errors_of(const Record& r) {
    std::array<bool, kErrorKinds> is{};
    is[static_cast<std::size_t>(ErrorKind::crc)] =
        r.frame.crc.status == CrcStatus::bad || r.frame.crc.status == CrcStatus::swapped;
    is[static_cast<std::size_t>(ErrorKind::no_answer)] = r.went_unanswered();
    is[static_cast<std::size_t>(ErrorKind::exception)] = r.kind == Kind::exception;
    is[static_cast<std::size_t>(ErrorKind::unsolicited)] = r.answers_no_request();
    is[static_cast<std::size_t>(ErrorKind::noise)] = r.kind == Kind::noise;
    return is;
}

template <class Bucket>
void halve(std::vector<Bucket>& buckets) {
    std::vector<Bucket> merged((buckets.size() + 1) / 2);
    for (std::size_t i = 0; i < buckets.size(); ++i) merged[i / 2].merge(buckets[i]);
    buckets.swap(merged);
}

template <class Bucket>
Bucket& at(std::vector<Bucket>& buckets, std::size_t i) {
    if (buckets.size() <= i) buckets.resize(i + 1);
    return buckets[i];
}

std::optional<double> number_of(const std::string& text) {
    double value = 0;
    const char* end = text.data() + text.size();
    const auto [ptr, ec] = std::from_chars(text.data(), end, value);
    if (ec != std::errc() || ptr != end || !std::isfinite(value)) return std::nullopt;
    return value;
}

double to_ms(Nanos t) {
    return static_cast<double>(t) / 1e6;
}

}  // namespace

const ErrorKindInfo& info(ErrorKind kind) {
    return kErrorKindInfo.at(static_cast<std::size_t>(kind));
}

void BusBucket::merge(const BusBucket& other) {
    frames += other.frames;
    for (std::size_t i = 0; i < kErrorKinds; ++i) errors.at(i) += other.errors.at(i);
}

void SlaveBucket::merge(const SlaveBucket& other) {
    requests += other.requests;
    answered += other.answered;
    turnarounds += other.turnarounds;
    turnaround_sum_ms += other.turnaround_sum_ms;
    turnaround_max_ms = std::max(turnaround_max_ms, other.turnaround_max_ms);
    cycles += other.cycles;
    cycle_sum_ms += other.cycle_sum_ms;
}

void ValueBucket::add(double value) {
    min = n == 0 ? value : std::min(min, value);
    max = n == 0 ? value : std::max(max, value);
    sum += value;
    ++n;
}

void ValueBucket::merge(const ValueBucket& other) {
    if (other.n == 0) return;
    min = n == 0 ? other.min : std::min(min, other.min);
    max = n == 0 ? other.max : std::max(max, other.max);
    sum += other.sum;
    n += other.n;
}

std::size_t histogram_bin(double milliseconds) {
    if (!(milliseconds >= kHistogramLowestMs)) return 0;
    const double tenths = std::floor(std::log10(milliseconds / kHistogramLowestMs) * kBinsPerDecade);
    return std::min(kHistogramBins - 1, static_cast<std::size_t>(tenths) + 1);
}

double histogram_edge_ms(std::size_t i) {
    if (i == 0) return 0;
    return kHistogramLowestMs * std::pow(10.0, static_cast<double>(i - 1) / kBinsPerDecade);
}

void Series::begin(const SessionInfo& session) {
    session_ = session;
}

std::size_t Series::bucket_of(Nanos time) {
    if (!has_time(origin_)) origin_ = time;
    if (time <= origin_) return 0;
    while (static_cast<std::uint64_t>(time - origin_) / static_cast<std::uint64_t>(width_) >=
           kMaxBuckets) {
        widen();
    }
    return static_cast<std::size_t>((time - origin_) / width_);
}

void Series::widen() {
    width_ *= 2;
    halve(bus_);
    for (auto& [slave, s] : slaves_) halve(s.buckets);
    for (ValueSeries& v : values_) halve(v.buckets);
}

void Series::add(const Record& record) {
    keep_flagged(record);
    // What a stop cut short was no fault of the bus's.
    if (record.notes.has(note_id::cut_by_stop)) return;
    const Nanos time = record.frame.start;
    if (!has_time(time)) {
        ++untimed_;
        return;
    }
    const std::size_t bucket = bucket_of(time);
    BusBucket& b = at(bus_, bucket);
    if (record.kind != Kind::noise) ++b.frames;
    const auto errors = errors_of(record);
    for (std::size_t i = 0; i < kErrorKinds; ++i) b.errors.at(i) += errors.at(i) ? 1 : 0;
    // A slave's figures only from frames whose address can be believed.
    if (record.frame.crc.status == CrcStatus::ok && record.kind != Kind::noise &&
        record.kind != Kind::invalid && record.frame.bytes.size() >= 2) {
        count_slave(record, bucket);
        count_values(record, bucket);
    }
}

void Series::count_slave(const Record& record, std::size_t bucket) {
    const Frame& f = record.frame;
    SlaveSeries& s = slaves_[f.slave()];
    ++s.frames;
    SlaveBucket& b = at(s.buckets, bucket);
    if (record.awaits_answer && !record.notes.has(note_id::stopped_before_answer)) {
        ++b.requests;
        if (record.answer_number != 0) ++b.answered;
    }
    if (record.kind == Kind::request) {
        PollKey key{f.slave(), static_cast<std::uint8_t>(f.function() & 0x7FU), {}, 0};
        const std::size_t data = f.bytes.size() >= 4 ? f.bytes.size() - 4 : 0;
        key.size = static_cast<std::uint8_t>(std::min<std::size_t>(data, 4));
        std::copy_n(f.bytes.begin() + 2, key.size, key.data.begin());
        auto last = poll_last_.find(key);
        if (last != poll_last_.end()) {
            if (f.start > last->second) {
                ++b.cycles;
                b.cycle_sum_ms += static_cast<float>(to_ms(f.start - last->second));
            }
            last->second = f.start;
        } else if (poll_last_.size() < BusStats::kMaxPolls) {
            poll_last_.emplace(key, f.start);
        }
    }
    if ((record.kind == Kind::response || record.kind == Kind::exception) &&
        record.request_number != 0 && has_time(record.latency)) {
        const double ms = to_ms(record.latency);
        ++b.turnarounds;
        b.turnaround_sum_ms += static_cast<float>(ms);
        b.turnaround_max_ms = std::max(b.turnaround_max_ms, static_cast<float>(ms));
        ++s.histogram.at(histogram_bin(ms));
    }
}

void Series::count_values(const Record& record, std::size_t bucket) {
    if (record.profile == nullptr) return;
    // Values in a request are what the master writes.
    const bool write = record.kind == Kind::request || record.kind == Kind::broadcast;
    for (const DecodedValue& v : record.values) {
        const std::optional<double> number = number_of(v.value);
        if (!number) continue;
        const std::uint32_t key = record.frame.slave() * 65536U + v.address;
        auto it = value_index_.find(key);
        if (it == value_index_.end()) {
            if (values_.size() >= kMaxValueSeries) {
                ++values_left_out_;
                continue;
            }
            it = value_index_.emplace(key, values_.size()).first;
            ValueSeries series;
            series.slave = record.frame.slave();
            series.profile = record.profile->name;
            series.address = v.address;
            series.name = v.name;
            series.unit = v.unit;
            values_.push_back(std::move(series));
        }
        ValueSeries& s = values_[it->second];
        at(s.buckets, bucket).add(*number);
        if (s.last) {
            const double step = std::abs(*number - *s.last);
            s.step_sum += step;
            ++s.steps;
            if (step > s.max_step) {
                s.max_step = step;
                s.max_step_time = record.frame.start;
            }
        }
        s.last = number;
        if (write) {
            ++s.write_count;
            if (s.writes.size() < kMaxWriteMarks) s.writes.push_back({record.frame.start, v.value});
        }
    }
}

void Series::keep_flagged(const Record& record) {
    if (record.notes.empty()) return;
    ++flagged_count_;
    if (flagged_.size() >= max_flagged_) return;
    FlaggedRecord f;
    f.number = record.number;
    f.time = record.frame.start;
    f.slave = record.frame.slave();
    f.function = record.frame.function();
    f.kind = std::string(to_string(record.kind));
    for (const Note& note : record.notes) f.notes.emplace_back(note.id, note.text);
    flagged_.push_back(std::move(f));
}

}  // namespace rtuscope::report
