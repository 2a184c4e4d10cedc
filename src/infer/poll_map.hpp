// Stage 1 of `profiles infer`: the poll map of each slave, from the records of a capture.
// Which registers and bits the master reads, with which function, in which blocks and how
// often; which it writes and with what; and every value each register answered, in order,
// tagged with the answer it came in (so that registers read together can be lined up).
#pragma once

#include <compare>
#include <cstdint>
#include <map>
#include <span>
#include <string>
#include <tuple>
#include <vector>

#include "pairing/transactions.hpp"
#include "util/time.hpp"

namespace rtuscope::infer {

// The four standard data tables, named as a profile names them.
enum class Table : std::uint8_t { coil, discrete, holding, input };
const char* table_name(Table table);
// Whether the table holds single bits (coils, discrete inputs) rather than registers.
bool is_bit_table(Table table);

struct RegisterKey {
    Table table = Table::holding;
    std::uint16_t address = 0;
    auto operator<=>(const RegisterKey&) const = default;  // NOLINT(modernize-use-nullptr)
};

// One value of one register (or bit: 0 or 1), from one answer.
struct Sample {
    std::uint64_t answer = 0;  // the answer's record number
    Nanos time = kNoTime;      // the answer's start
    std::uint16_t value = 0;
};

// A block the master reads: one function, start and count, and when it was answered.
struct ReadBlock {
    Table table = Table::holding;
    std::uint8_t function = 0;
    std::uint16_t start = 0;
    std::uint16_t count = 0;
    std::uint64_t polls = 0;    // answered reads
    std::vector<Nanos> times;   // their times (the first kMaxSamples)
    auto key() const { return std::tuple(table, function, start, count); }
};

// What the master wrote into one register or coil.
struct WriteSeen {
    std::uint64_t count = 0;
    std::vector<std::uint8_t> functions;  // codes used, in the order first seen
    std::vector<std::uint16_t> values;    // distinct values, first kMaxWrittenValues
};

struct SlaveTraffic {
    std::uint8_t slave = 0;
    std::vector<ReadBlock> blocks;  // in the order first seen
    std::map<RegisterKey, std::vector<Sample>> reads;
    std::map<RegisterKey, WriteSeen> writes;
    std::uint64_t answered_reads = 0;
    std::uint64_t exceptions = 0;
};

// Samples kept per register and times per block: a capture of days is still read to its
// end, its first values are enough to type a register.
inline constexpr std::size_t kMaxSamples = 100'000;
inline constexpr std::size_t kMaxWrittenValues = 16;

class PollMapBuilder {
  public:
    // Any record: answers to reads and writes (and broadcast writes) are taken, the rest
    // (exceptions counted) passed over; malformed PDUs are passed over too.
    void add(const Record& record);
    // The slaves seen, by address.
    [[nodiscard]] const std::map<std::uint8_t, SlaveTraffic>& slaves() const { return slaves_; }

  private:
    void add_read(SlaveTraffic& slave, const Record& record, std::span<const std::uint8_t> request,
                  std::span<const std::uint8_t> answer);
    void add_write(SlaveTraffic& slave, std::span<const std::uint8_t> request);
    std::map<std::uint8_t, SlaveTraffic> slaves_;
};

// Median of the intervals between consecutive times (kNoTime when fewer than two times).
Nanos median_period(const std::vector<Nanos>& times);

}  // namespace rtuscope::infer
