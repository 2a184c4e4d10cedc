// Stage 1 for live lines: a serial port (or two, for a full-duplex tap) read passively.
// The port is opened read-only and never written to; bytes are timestamped as they are
// read, with a monotonic clock mapped to wall time.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "framing/line_settings.hpp"
#include "input/chunk.hpp"
#include "util/result.hpp"
#include "util/time.hpp"

namespace rtuscope {

struct TtyOptions {
    // One port, or two (a full-duplex tap: one port per direction, merged by time; each
    // chunk carries its port's channel name).
    std::vector<std::string> ports;
    // Channel names of the ports' chunks; default "master" (the first port, which hears
    // the master's requests) and "slave" (the second, the answers): see
    // FramerOptions::request_channel.
    std::vector<std::string> channels;
    LineSettings line;
    std::optional<Nanos> duration;            // stop after this long (--seconds)
    const std::atomic<bool>* stop = nullptr;  // set by SIGINT/SIGTERM: stop cleanly
    Nanos tick = 5'000'000;                   // idle ticks while nothing arrives
    // A port that goes away (an adapter unplugged) is waited for and opened again with
    // the same settings, rather than ending the run; the chunk after the wait says how
    // long nothing was heard (Chunk::gap_since), and the source's remarks list the gaps.
    bool reopen = false;
    Nanos reopen_poll = 500'000'000;  // how often a port that went away is looked for
    // Told at once when a port goes away and when it is back (sniff prints it).
    std::function<void(const std::string&)> on_notice;
};

// Opens and configures the ports (raw, the line's speed and character format, parity
// and framing errors marked, low latency where the driver allows). Errors are one line
// that names the fix where there is one (a missing port, the dialout group).
// `notices`, when given, receives what the user should be told once (a driver that
// refuses low-latency mode).
Result<std::unique_ptr<ChunkSource>> open_tty_source(const TtyOptions& options,
                                                     std::vector<std::string>* notices = nullptr);

// Unescapes what a tty with PARMRK delivers: 0xFF 0xFF is a data byte 0xFF; 0xFF 0x00 X
// is byte X received with a parity or framing error (X = 0 also for a break). The state
// carries an escape that a read() split in two.
class ParmrkDecoder {
  public:
    // Appends the data bytes of `in` to `out` and the offsets (in `out`) of bytes that
    // came with an error to `errors`.
    void feed(std::span<const std::uint8_t> in, std::vector<std::uint8_t>& out,
              std::vector<std::uint32_t>& errors);

  private:
    int pending_ = 0;  // 0xFF bytes of an escape seen so far: 0, 1 (FF) or 2 (FF 00)
};

// When a port is read and how what it gives is stamped. The first byte after a silence
// wakes the reader at once and is stamped as it arrives. While a frame keeps coming, the
// port is read once every t1.5 rather than at every byte: a wake-up per byte costs more
// CPU than all the decoding (on a busy 115200-baud line, ten thousand a second). A read
// that finds fewer bytes than its window could hold ends the batching, so that the next
// byte again wakes the reader at once; its bytes are stamped as following on from the
// read before, the silence after them. So every silence of t1.5 or more (the least the
// specification counts as the end of a frame) is measured as exactly as the port
// delivers bytes; a shorter one with bytes after it in the same window is placed after
// those bytes.
class ReadBatcher {
  public:
    explicit ReadBatcher(const LineSettings& line)
        : char_time_(line.char_time()), window_(line.t15()) {}
    // Bytes just read at `now` (monotonic): the time to stamp their last byte with.
    Nanos stamp(Nanos now, std::size_t count);
    // Whether the next read waits for the window rather than for the next byte.
    [[nodiscard]] bool batching() const { return batching_; }
    // When a batching port is read next.
    [[nodiscard]] Nanos next_read() const { return last_read_ + window_; }

  private:
    Nanos char_time_;
    Nanos window_;
    bool batching_ = false;
    Nanos last_read_ = 0;
};

}  // namespace rtuscope
