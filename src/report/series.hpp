// What `rtuscope report` draws, collected record by record in bounded memory: the bus's
// frames and errors over time, each slave's turnarounds and poll cycle over time and its
// turnaround histogram, each register's values over time (writes marked), and the first
// flagged records. The figures that `stats` prints are not here: the page takes those
// from stats/ (BusStats and its JSON Lines), so that they are the same figures.
//
// Every series shares one row of time buckets. The buckets start 100 ms wide; when a
// time falls beyond the last of kMaxBuckets, the width doubles and each two neighbours
// merge into one, so a capture of any length keeps at most kMaxBuckets points a series
// (a day at ~90 s a point) and memory does not grow with the capture.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "pipeline.hpp"
#include "stats/bus_stats.hpp"

namespace rtuscope::report {

inline constexpr std::size_t kMaxBuckets = 1000;
inline constexpr Nanos kFirstBucketWidth = 100'000'000;
// Registers charted, the first met: a profile of hundreds of registers would otherwise
// make a page of hundreds of charts.
inline constexpr std::size_t kMaxValueSeries = 48;
// Writes marked per register chart.
inline constexpr std::size_t kMaxWriteMarks = 500;
// Turnaround histogram: bins of a tenth of a decade from 10 µs to 100 s, and one each
// below and above.
inline constexpr int kHistogramDecades = 7;
inline constexpr int kBinsPerDecade = 10;
inline constexpr std::size_t kHistogramBins = kHistogramDecades * kBinsPerDecade + 2;
inline constexpr double kHistogramLowestMs = 0.01;

// The errors the timeline counts, each a series of its own.
enum class ErrorKind : std::uint8_t { crc, no_answer, exception, unsolicited, noise, count };
struct ErrorKindInfo {
    const char* id;     // the JSON key
    const char* label;  // the chart's legend
};
const ErrorKindInfo& info(ErrorKind kind);
inline constexpr std::size_t kErrorKinds = static_cast<std::size_t>(ErrorKind::count);

struct BusBucket {
    std::uint32_t frames = 0;
    std::array<std::uint32_t, kErrorKinds> errors{};
    void merge(const BusBucket& other);
};

// Sums rather than lists: a bucket's mean and max are what the chart shows.
struct SlaveBucket {
    std::uint32_t requests = 0;  // awaiting an answer
    std::uint32_t answered = 0;  // of them, answered (normally or by an exception)
    std::uint32_t turnarounds = 0;
    float turnaround_sum_ms = 0;
    float turnaround_max_ms = 0;
    std::uint32_t cycles = 0;
    float cycle_sum_ms = 0;
    void merge(const SlaveBucket& other);
};

struct SlaveSeries {
    std::uint64_t frames = 0;  // to rank the slaves
    std::vector<SlaveBucket> buckets;
    std::array<std::uint64_t, kHistogramBins> histogram{};
};

struct ValueBucket {
    std::uint32_t n = 0;
    double min = 0;
    double max = 0;
    double sum = 0;
    void add(double value);
    void merge(const ValueBucket& other);
};

struct WriteMark {
    Nanos time = 0;
    std::string value;
};

// A register's numeric values; enum labels, bit names and strings have no line to draw.
struct ValueSeries {
    std::uint8_t slave = 0;
    std::string profile;
    std::uint16_t address = 0;
    std::string name;
    std::string unit;
    std::vector<ValueBucket> buckets;
    std::vector<WriteMark> writes;
    std::uint64_t write_count = 0;
    // The largest step between two successive values, against the mean step: a value that
    // jumps.
    std::optional<double> last;
    double step_sum = 0;
    std::uint64_t steps = 0;
    double max_step = 0;
    Nanos max_step_time = kNoTime;
};

struct FlaggedRecord {
    std::uint64_t number = 0;
    Nanos time = kNoTime;
    std::uint8_t slave = 0;
    std::uint8_t function = 0;
    std::string kind;
    std::vector<std::pair<std::string, std::string>> notes;  // id, text
};

class Series {
  public:
    explicit Series(std::size_t max_flagged) : max_flagged_(max_flagged) {}

    void begin(const SessionInfo& session);
    void add(const Record& record);

    [[nodiscard]] const SessionInfo& session() const { return session_; }
    // The first bucket's start; kNoTime until a timed record came.
    [[nodiscard]] Nanos origin() const { return origin_; }
    [[nodiscard]] Nanos width() const { return width_; }
    [[nodiscard]] const std::vector<BusBucket>& bus() const { return bus_; }
    [[nodiscard]] const std::map<std::uint8_t, SlaveSeries>& slaves() const { return slaves_; }
    [[nodiscard]] const std::vector<ValueSeries>& values() const { return values_; }
    // Registers with numbers that had no room among kMaxValueSeries.
    [[nodiscard]] std::uint64_t values_left_out() const { return values_left_out_; }
    [[nodiscard]] const std::vector<FlaggedRecord>& flagged() const { return flagged_; }
    [[nodiscard]] std::uint64_t flagged_count() const { return flagged_count_; }
    [[nodiscard]] std::size_t max_flagged() const { return max_flagged_; }
    // Records without a time: they count in the flagged list and nowhere on a chart.
    [[nodiscard]] std::uint64_t untimed() const { return untimed_; }

  private:
    // The bucket of `time`, widening the buckets as far as it takes.
    std::size_t bucket_of(Nanos time);
    void widen();
    void count_slave(const Record& record, std::size_t bucket);
    void count_values(const Record& record, std::size_t bucket);
    void keep_flagged(const Record& record);

    SessionInfo session_;
    std::size_t max_flagged_;
    Nanos origin_ = kNoTime;
    Nanos width_ = kFirstBucketWidth;
    std::vector<BusBucket> bus_;
    std::map<std::uint8_t, SlaveSeries> slaves_;
    // A request's last time per poll (as stats/ keys polls), for the cycle; at most
    // BusStats::kMaxPolls, later polls have no cycle drawn.
    std::map<PollKey, Nanos> poll_last_;
    // By slave * 65536 + address: a register's name comes with its address.
    std::map<std::uint32_t, std::size_t> value_index_;
    std::vector<ValueSeries> values_;
    std::uint64_t values_left_out_ = 0;
    std::vector<FlaggedRecord> flagged_;
    std::uint64_t flagged_count_ = 0;
    std::uint64_t untimed_ = 0;
};

// The histogram bin of a turnaround.
std::size_t histogram_bin(double milliseconds);
// The lower edge of histogram bin `i` in ms (bin 0: below kHistogramLowestMs).
double histogram_edge_ms(std::size_t i);

}  // namespace rtuscope::report
