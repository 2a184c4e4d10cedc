// Bus statistics: `rtuscope stats FILE` and the end-of-run summary of `sniff`. A sink
// that counts records per slave and function code instead of printing them, and prints
// the figures (counts, turnaround percentiles, poll cycles, bus utilisation) at the end
// as an aligned text table, CSV or JSON lines.
//
// Memory: counters per slave/function and per poll (a map entry of ~100 bytes per
// distinct request: a master writing many different values makes many), plus one Nanos
// per measured turnaround and per repeated poll request, kept because exact percentiles
// need every value. It grows with the capture: `scripts/bench`'s 1M-frame capture
// (295,000 distinct requests, 480,000 turnarounds) peaks at 45 MiB. The frames
// themselves are never kept.
#pragma once

#include <array>
#include <cstdint>
#include <cstdio>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "rtuscope/pipeline.hpp"

namespace rtuscope {

enum class StatsFormat : std::uint8_t { text, csv, jsonl };

// Nearest-rank percentile of sorted values: the smallest value that at least `percent`
// per cent of the values are less than or equal to, i.e. sorted[ceil(percent/100 * n) - 1].
// Always one of the measured values, never an interpolation. nullopt when empty.
std::optional<Nanos> nearest_rank(std::span<const Nanos> sorted, unsigned percent);

// Figures of one slave and function code (the function without its exception bit).
struct FunctionStats {
    std::uint64_t requests = 0;
    std::uint64_t answers = 0;     // normal answers (Kind::response), unsolicited ones too
    std::uint64_t exceptions = 0;  // exception answers, also counted per code below
    std::map<std::uint8_t, std::uint64_t> exception_codes;
    std::uint64_t crc_errors = 0;   // frames with a bad or swapped CRC, whatever their kind
    std::uint64_t no_answer = 0;    // requests noted txn.no_answer
    std::uint64_t broadcasts = 0;   // requests to the broadcast address
    std::uint64_t unsolicited = 0;  // answers and exceptions noted txn.unsolicited
    // End of request to start of answer, for normal and exception answers alike (both
    // show how fast the device reacts), where the input has timing. Sorted by finish().
    std::vector<Nanos> turnarounds;
};

// A poll: requests with the same slave, function and first 4 data bytes (for reads the
// start address and quantity). Its cycle is the time between two successive requests.
struct PollKey {
    std::uint8_t slave = 0;
    std::uint8_t function = 0;
    std::array<std::uint8_t, 4> data{};
    std::uint8_t size = 0;  // data bytes the request had, up to 4

    // clang-tidy 14 mistakes the defaulted comparison's literal 0 for a null pointer.
    auto operator<=>(const PollKey&) const = default;  // NOLINT(modernize-use-nullptr)
};

struct PollStats {
    std::uint64_t requests = 0;
    Nanos last_start = kNoTime;
    std::vector<Nanos> cycles;  // sorted by finish()
};

struct BusFigures {
    Nanos first_start = kNoTime;  // of the first timed record
    Nanos last_end = kNoTime;     // of the last timed record
    std::uint64_t frames = 0;     // records that are not noise
    std::uint64_t bytes = 0;      // every byte on the line, noise included
    std::uint64_t noise_runs = 0;
    std::uint64_t noise_bytes = 0;
    std::uint64_t invalid = 0;  // bad CRC or cut short
    std::uint64_t unknown = 0;  // valid frames whose role is unclear
};

class BusStats {
  public:
    using Key = std::pair<std::uint8_t, std::uint8_t>;  // slave, function & 0x7F

    void begin(const SessionInfo& session) { session_ = session; }
    void add(const Record& record);
    // Sorts what the percentiles need; call once, after the last add().
    void finish();

    [[nodiscard]] const SessionInfo& session() const { return session_; }
    [[nodiscard]] const std::map<Key, FunctionStats>& functions() const { return functions_; }
    [[nodiscard]] const std::map<PollKey, PollStats>& polls() const { return polls_; }
    [[nodiscard]] const BusFigures& bus() const { return bus_; }
    // Every slave and function summed, turnarounds pooled (sorted).
    [[nodiscard]] const FunctionStats& all() const { return all_; }

    [[nodiscard]] bool timed() const;
    [[nodiscard]] std::optional<Nanos> duration() const;
    // Per cent of the time the line carried a character; nullopt without timing.
    [[nodiscard]] std::optional<double> utilisation() const;
    // The poll with the most requests (ties: the lowest key) among those of one slave and
    // function, or of the whole bus when `key` is nullopt. Its cycle stands for the
    // row's cycle: a master usually repeats one poll list, so every poll of it shows the
    // same cycle, and one typical poll says more than a median pooled across polls of
    // different rates.
    [[nodiscard]] const std::pair<const PollKey, PollStats>* main_poll(
        std::optional<Key> key) const;

  private:
    SessionInfo session_;
    std::map<Key, FunctionStats> functions_;
    std::map<PollKey, PollStats> polls_;
    BusFigures bus_;
    FunctionStats all_;
};

// The statistics as `format` prints them; `remarks` are the source's (text only).
std::string render_stats(const BusStats& stats, StatsFormat format,
                         const std::vector<std::string>& remarks = {});

// A RecordSink that counts instead of printing records; end() prints the statistics.
std::unique_ptr<RecordSink> make_stats_sink(std::FILE* out, StatsFormat format);

}  // namespace rtuscope
