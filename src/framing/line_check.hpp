// Whether the input looks like a Modbus RTU line at the settings in use: the share of its
// bytes that land in frames with a valid CRC, and whether bytes timed one by one (a logic
// analyser's export) come faster than a character of the baud rate lasts. What it finds
// is said in plain words at the end of a run; nothing is dropped or changed.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "framing/char_time.hpp"
#include "framing/frame.hpp"
#include "framing/line_settings.hpp"
#include "input/chunk.hpp"

namespace rtuscope {

class LineCheck {
  public:
    explicit LineCheck(LineSettings line) : line_(line) {}

    void chunk(const Chunk& chunk);
    void frame(const Frame& frame);
    // One sentence per thing that looks wrong; none when the input looks like RTU.
    [[nodiscard]] std::vector<std::string> remarks() const;

  private:
    LineSettings line_;
    std::uint64_t bytes_ = 0;
    std::uint64_t valid_bytes_ = 0;  // in frames with a right (or swapped) CRC
    // Bytes that came one a chunk right after another such byte: how many, and how many
    // of them sooner than a character takes at the baud rate.
    Nanos last_single_ = kNoTime;
    std::uint64_t single_pairs_ = 0;
    std::uint64_t too_soon_ = 0;
    // The rate to suggest.
    CharTimeEstimator char_time_;
};

}  // namespace rtuscope
