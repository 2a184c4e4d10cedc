// How an input hands its bytes over, learned from its own timestamps.
//
// A chunk's time is when its last byte was handed over, which is not always when it came
// off the line: a USB adapter holds bytes until its latency timer runs out (16 ms by
// default, 1 ms in low-latency mode), a UART's FIFO until its trigger level fills or the
// line has been quiet for 4 characters. The silence measured between two chunks may then
// be longer than the one on the line: by up to how long the adapter may hold a byte. A
// silence is proven only when it is longer than t3.5 by at least that much.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "framing/line_settings.hpp"
#include "input/chunk.hpp"
#include "util/time.hpp"

namespace rtuscope {

struct Batching {
    enum class Kind : std::uint8_t {
        unknown,   // too few chunks to tell, or no pattern: times taken as they are
        per_byte,  // each byte alone (a logic analyser, a port read a byte at a time)
        timer,     // a latency timer: chunks at least `period` apart
        fifo,      // a UART FIFO: `fifo_trigger` bytes back to back, the rest after a pause
    };
    Kind kind = Kind::unknown;
    Nanos period = 0;              // timer
    std::size_t fifo_trigger = 0;  // fifo
    // How much later than it ended a byte may be handed over; a measured silence can be
    // that much longer than the one on the line.
    Nanos hold = 0;

    // For the header line ("chunks every 16 ms: silences under 16 ms cannot be seen");
    // empty when the times can be taken as they are.
    [[nodiscard]] std::string text() const;
};

// Watches the chunks of an input whose times are their last bytes' ends. Its verdict is
// settled after kChunksToSettle chunks with bytes; before that it is the best so far.
class BatchingLearner {
  public:
    explicit BatchingLearner(const LineSettings& line)
        : char_time_(line.char_time()), slowest_pace_(line.char_time() + line.t15()) {}

    void chunk(const Chunk& chunk);
    [[nodiscard]] bool settled() const { return chunks_ >= kChunksToSettle; }
    [[nodiscard]] Batching verdict() const;

    static constexpr std::size_t kChunksToSettle = 256;

    struct Sample {
        Nanos interval = 0;  // since the chunk before
        std::size_t bytes = 0;
        bool follows_previous = false;  // the sample before it is its chunk's predecessor
        // How long its bytes take, back to back, at `pace` a character.
        [[nodiscard]] Nanos bytes_at(Nanos pace) const { return static_cast<Nanos>(bytes) * pace; }
    };

  private:
    Nanos char_time_;
    // A sender's characters are at most t1.5 apart within a frame.
    Nanos slowest_pace_;
    Nanos last_time_ = kNoTime;
    bool last_sampled_ = false;  // the last chunk's interval is a sample
    std::size_t chunks_ = 0;
    std::size_t single_bytes_ = 0;
    std::vector<Sample> samples_;
};

}  // namespace rtuscope
