// Bus statistics: `rtuscope stats FILE` and the end-of-run summary of `sniff`. A sink
// that counts records per slave and function code instead of printing them, and prints
// the figures (counts, turnaround percentiles, poll cycles, bus utilisation) at the end
// as an aligned text table, CSV or JSON lines.
//
// Memory does not grow with the capture, so that a sniffer can run for weeks and `stats`
// reads a capture of any length: durations are counted per distinct value in bounded
// tables (DurationCounts, at most ~22 KiB each), one per row and per poll, whose bins
// share a budget of ~12 MiB on a large bus (BusStats::kBinBudget); there are at most
// kMaxPolls polls and 256 x 128 rows (~8 MiB of counters if noise hit every slave and
// function); the output is written in pieces as it is made. The frames themselves are
// never kept.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <utility>

#include "framing/functions.hpp"
#include "pipeline.hpp"
#include "stats/durations.hpp"

namespace rtuscope {

// Figures of one slave and function code (the function without its exception bit). Every
// request that awaits an answer has one outcome: requests = answers + exceptions + broken +
// no_answer.
struct FunctionStats {
    // The entry its frames were decoded by (a device's own where its profile has one),
    // nullptr until one is known.
    const FunctionSpec* function = nullptr;
    std::uint64_t requests = 0;    // requests awaiting an answer, their CRC right or not
    std::uint64_t answers = 0;     // normal answers (Kind::response) to a request
    std::uint64_t exceptions = 0;  // exception answers to a request
    std::uint64_t broken = 0;      // answers to a request with a bad CRC or cut short
    // Per code, every exception answer (answering a request or not), within
    // BusStats::kMaxExceptionCodes over all rows.
    std::map<std::uint8_t, std::uint64_t> exception_codes;
    std::uint64_t crc_errors = 0;  // frames with a bad or swapped CRC, whatever their kind
    std::uint64_t no_answer = 0;   // requests noted txn.no_answer
    std::uint64_t broadcasts = 0;  // requests to the broadcast address
    // Answers that answer no waiting request: nobody asked (txn.unsolicited), or a second
    // answer to one request (txn.duplicate_answer: two devices on one address).
    std::uint64_t unsolicited = 0;
    // End of request to start of answer, for every kind of answer to a request (each shows
    // how fast the device reacts), where the input has timing.
    DurationCounts turnarounds;
};

// Adds `from`'s counts to `into`'s, turnarounds pooled (`from`'s finished first).
void merge_function_stats(FunctionStats& into, const FunctionStats& from);
// The same but for the turnarounds, left as they are: the counts alone cost no merge.
void add_function_counts(FunctionStats& into, const FunctionStats& from);

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
    std::uint64_t first_request = 0;  // BusStats' count of requests when it came first
    Nanos last_start = kNoTime;
    DurationCounts cycles;
};

struct BusFigures {
    Nanos first_start = kNoTime;  // of the first timed record
    Nanos last_end = kNoTime;     // of the last timed record
    std::uint64_t frames = 0;     // records that are not noise
    std::uint64_t bytes = 0;      // every byte on the line, noise included
    // Of them, bytes of Modbus/TCP frames (unit id and PDU): they took no time on a
    // serial line, so the utilisation leaves them out.
    std::uint64_t tcp_bytes = 0;
    std::uint64_t noise_runs = 0;
    std::uint64_t noise_bytes = 0;
    std::uint64_t invalid = 0;  // bad CRC or cut short
    std::uint64_t unknown = 0;  // valid frames whose role is unclear
};

class BusStats {
  public:
    using Key = std::pair<std::uint8_t, std::uint8_t>;  // slave, function & 0x7F

    // The bins of every row's turnarounds and every poll's cycles, shared. A set of at
    // most kMinDistinct values needs no more bins than that; the sets of more share what
    // those leave of kBinBudget: DurationCounts::kMaxDistinct each while that fits, else a
    // power of two, never below kMinDistinct. A bin takes ~22 bytes (room for a batch
    // included), so a bus of 247 slaves answering several functions each, or noise that
    // reached every row, keeps to ~12 MiB of them.
    static constexpr std::size_t kBinBudget = std::size_t{1} << 19;
    static constexpr std::size_t kMinDistinct = 16;

    // Exceptions are counted per code for up to this many slave/function/code triples:
    // a real bus has a few dozen, but crafted or garbage input can bring 247 x 127 x 256
    // (8 million, ~400 MiB of them); the exceptions of any further triple still count in
    // their row, and in unlisted_exceptions().
    static constexpr std::size_t kMaxExceptionCodes = 8192;

    // Distinct requests kept as polls: more than a master polls in a cycle (247 slaves x
    // 16 registers). A full table forgets the quarter of its polls that came least often
    // for the time they have been in it (by requests, not by clock, so untimed input is
    // treated alike): one-off writes and rare requests go, a master's poll list stays.
    static constexpr std::size_t kMaxPolls = 4096;
    // That time counts as at least this many requests of the bus. A poll seen once lately
    // has shown no rate yet: ranked by its own short time it would rank first, and the
    // table would forget each poll of a list longer than itself before it came again (no
    // cycle at all). Counted so, the polls seen once in that time rank alike (the lowest
    // keys go first), and the rest of the list stays and repeats.
    static constexpr std::uint64_t kPollHorizon = 16 * kMaxPolls;

    void begin(const SessionInfo& session) { session_ = session; }
    void add(const Record& record);
    // Counts what the percentiles need; call once, after the last add().
    void finish();

    [[nodiscard]] const SessionInfo& session() const { return session_; }
    [[nodiscard]] const std::map<Key, FunctionStats>& functions() const { return functions_; }
    [[nodiscard]] const std::map<PollKey, PollStats>& polls() const { return polls_; }
    [[nodiscard]] const BusFigures& bus() const { return bus_; }
    // Every slave and function summed, turnarounds pooled.
    [[nodiscard]] const FunctionStats& all() const { return all_; }
    // Bins each row's turnarounds and each poll's cycles may hold now (kBinBudget).
    [[nodiscard]] std::size_t bins_each() const { return max_distinct_; }
    // Exceptions not counted per code, their triple beyond kMaxExceptionCodes.
    [[nodiscard]] std::uint64_t unlisted_exceptions() const { return unlisted_exceptions_; }
    // Polls forgotten to keep the table within kMaxPolls.
    [[nodiscard]] std::uint64_t forgotten_polls() const { return forgotten_polls_; }

    [[nodiscard]] bool timed() const;
    [[nodiscard]] std::optional<Nanos> duration() const;
    // Per cent of the time the line carried a character; nullopt without timing or
    // without a byte of a serial line (Modbus/TCP alone).
    [[nodiscard]] std::optional<double> utilisation() const;
    // False when the bytes would take longer than the input lasts: the baud rate is wrong.
    [[nodiscard]] bool utilisation_possible() const {
        return !utilisation() || *utilisation() <= 100.0;
    }
    // The poll with the most requests (ties: the lowest key) among those of one slave and
    // function, or of the whole bus when `key` is nullopt. Its cycle stands for the
    // row's cycle: a master usually repeats one poll list, so every poll of it shows the
    // same cycle, and one typical poll says more than a median pooled across polls of
    // different rates.
    [[nodiscard]] const std::pair<const PollKey, PollStats>* main_poll(
        std::optional<Key> key) const;

  private:
    void count_poll(const Key& key, const Record& record);
    void count_answer(FunctionStats& s, const Record& record);
    // An answer whose end the capture's snap length cut (frame.cut_by_snaplen).
    void count_cut_answer(const Record& record);
    PollStats& poll_of(const PollKey& key);
    void forget_rare_polls();
    void add_duration(DurationCounts& counts, Nanos value);
    void count_exception_code(FunctionStats& row, std::uint8_t code);
    void forget_duration_set(const DurationCounts& counts);
    void share_bins();

    SessionInfo session_;
    std::map<Key, FunctionStats> functions_;
    std::map<PollKey, PollStats> polls_;
    std::uint64_t requests_ = 0;  // to date, for the polls' ages
    std::uint64_t forgotten_polls_ = 0;
    std::size_t exception_codes_ = 0;  // slave/function/code triples counted
    std::uint64_t unlisted_exceptions_ = 0;
    // Rows' turnarounds and polls' cycles with 1 to kMinDistinct values, and with more.
    std::size_t few_value_sets_ = 0;
    std::size_t many_value_sets_ = 0;
    std::size_t max_distinct_ = DurationCounts::kMaxDistinct;  // each one's share of the bins
    BusFigures bus_;
    FunctionStats all_;
};

}  // namespace rtuscope
