// Stage 2 of `profiles infer`: the values of a register, or of two registers read
// together, as a time series, and what can be measured on them without choosing a type
// yet: distinct values, steps, wraps, carries, readings as floats.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "infer/poll_map.hpp"

namespace rtuscope::infer {

// What the values of one 16-bit register (or one bit) show.
struct WordSeries {
    std::size_t samples = 0;
    std::vector<std::uint16_t> distinct;  // sorted, at most kMaxDistinct + 1 (then "many")
    std::uint16_t min = 0;
    std::uint16_t max = 0;
    std::size_t changes = 0;              // consecutive samples that differ
    std::uint32_t max_step_unsigned = 0;  // largest |change| read as u16
    std::uint32_t max_step_signed = 0;    // read as i16
    bool below_sign = false;              // some value < 0x8000
    bool above_sign = false;              // some value >= 0x8000
    bool non_decreasing = true;           // never goes down
    bool single_bit_changes = true;       // every change flips exactly one bit
    std::uint16_t toggled_bits = 0;       // bits that changed at some point
    bool multiples_of_10 = true;          // every value (as i16) a multiple of 10
    bool multiples_of_100 = true;

    [[nodiscard]] bool constant() const { return samples > 0 && changes == 0; }
    [[nodiscard]] bool many_values() const { return distinct.size() > kMaxDistinct; }
    static constexpr std::size_t kMaxDistinct = 16;
};

WordSeries measure_word(const std::vector<Sample>& samples);

// Two adjacent registers' values from the same answers, in order.
struct PairSeries {
    std::vector<std::uint16_t> first;   // the lower address
    std::vector<std::uint16_t> second;  // the next
};

// The pair, when every answer that holds one holds the other: the master always reads
// them together. nullopt otherwise.
std::optional<PairSeries> read_together(const std::vector<Sample>& first,
                                        const std::vector<Sample>& second);

// Which of the two registers holds the high word.
enum class HighWord : std::uint8_t { first, second };

// The pair read as a 32-bit integer with that high word, one value per sample.
std::vector<std::uint32_t> join_words(const PairSeries& pair, HighWord high);

// Carries (low word wraps up, high word +1) and borrows (low wraps down, high word -1) in
// the pair read with that high word; and the high word stepping without the low word
// wrapping (evidence against).
struct CarryCount {
    std::size_t carries = 0;
    std::size_t unexplained_high_steps = 0;
};
CarryCount count_carries(const PairSeries& pair, HighWord high);

// The pair read as IEEE 754 floats with that high word (abcd: first; cdab: second).
struct FloatReading {
    bool all_sane = false;         // finite; 0 or 1e-6 <= |x| <= 1e9 (no denormals)
    bool varies = false;           // not one value throughout
    double smooth_fraction = 0;    // steps under 10 % of the larger magnitude
    double min = 0;
    double max = 0;
    std::size_t low_word_changes = 0;
    std::size_t high_word_changes = 0;
};
FloatReading read_floats(const PairSeries& pair, HighWord high);

// Whether the series (as unsigned 32-bit values, or as signed) crosses zero with small
// steps: large steps as unsigned, small as signed.
struct SignedSteps {
    std::uint64_t max_step_unsigned = 0;
    std::uint64_t max_step_signed = 0;
    bool has_negative = false;  // top bit set somewhere
    bool has_positive = false;  // top bit clear somewhere
};
SignedSteps signed_steps32(const std::vector<std::uint32_t>& values);

}  // namespace rtuscope::infer
