// The character time a line keeps, read from bytes timed one by one (a logic analyser's
// export, a live port that hands bytes over as they come): back-to-back bytes of a frame
// follow each other one character apart, so the spacing most of them keep is the
// character time, and with it the baud rate and the bits per character. One estimator
// for `decode`'s warning when a capture's baud rate contradicts its timing and for
// `detect`.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "input/chunk.hpp"
#include "util/time.hpp"

namespace rtuscope {

struct CharTimeEstimate {
    Nanos char_time = 0;         // the spacing back-to-back bytes keep
    std::uint64_t intervals = 0;  // how many intervals keep it (within 3 %)
    std::uint64_t measured = 0;   // intervals between bytes timed one by one, in all
};

class CharTimeEstimator {
  public:
    // Counts the interval to the previous chunk when both are one byte with a time.
    void chunk(const Chunk& chunk);
    void reset();
    // None until enough intervals agree: 16, and 30 % of those measured.
    [[nodiscard]] std::optional<CharTimeEstimate> estimate() const;
    [[nodiscard]] std::uint64_t measured() const { return intervals_.size(); }

  private:
    Nanos last_single_ = kNoTime;
    std::vector<Nanos> intervals_;  // the first kMaxIntervals
};

// A baud rate and character length that give a character time.
struct CharTimeFit {
    std::uint32_t baud = 0;
    unsigned bits_per_char = 0;  // 10: 8N1 (7E1, 7O1, 7N2); 11: 8E1, 8O1, 8N2; 12: 8E2, 8O2
    double error = 0;             // |ln(measured / expected)|
};

// The rates of `bauds` (the standard ones when empty) at 10, 11 or 12 bits a character
// whose character time is within 4 % of `char_time`, best first.
std::vector<CharTimeFit> fit_char_time(Nanos char_time, std::span<const std::uint32_t> bauds = {});

// "11-bit characters (8E1, 8O1 or 8N2)": what a character length can be.
std::string describe_char_bits(unsigned bits_per_char);

}  // namespace rtuscope
