// Synthetic but realistic Modbus RTU traffic for the benchmarks: a master polling the four
// seed devices (with their quirks) and standard devices, as a USB adapter hands it over.
// Deterministic for a given seed on every platform (own PRNG, no <random> distributions).
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "input/chunk.hpp"

namespace rtuscope::bench {

struct TrafficOptions {
    std::uint64_t frames = 1'000'000;  // requests + answers (noise runs not counted)
    std::uint64_t seed = 1;
    std::uint32_t baud = 115200;  // 8N1
    // 0: the mix above. N: instead, every slave 1-247 asked functions 1..N in turn, each
    // answered by an exception: the largest statistics a bus can give (247 x N rows).
    std::uint32_t all_slaves_functions = 0;
    // Each byte a chunk of its own, timed when it ended, instead of a USB adapter's
    // batches: a logic analyser's export, like the captures in captures/realdata.
    bool per_byte = false;
    // Instead of the USB mix, one adapter's way: a latency timer of this length (an FTDI
    // chip's: 16 ms by default, 1 ms in low-latency mode) for every batch; or a 16550
    // UART's FIFO, handed over at its trigger level (14 bytes) or once the line has been
    // quiet for 4 characters (its receive timeout), each byte's time as the UART's.
    Nanos usb_timer = 0;
    bool uart_fifo = false;
    // A pause the senders leave between the characters of a frame (within t1.5): some
    // pause a bit each time, as the flow meter in captures/realdata does.
    Nanos char_pause = 0;
    // Frames with a bit flipped on the line, per thousand requests and per thousand answers.
    std::uint32_t damaged_per_mille = 5;
};

struct TrafficStats {
    std::uint64_t frames = 0;
    std::uint64_t bytes = 0;
    std::uint64_t chunks = 0;
};

// What the generator put on the line, in order: the truth a decode of the traffic is
// checked against (tests/test_bench_traffic.cpp).
struct SentFrame {
    enum class What : std::uint8_t {
        request,  // broadcasts too
        answer,   // exceptions too
        junk,     // the byte a slave's driver leaves behind
        noise,    // line noise between transactions
    };
    What what = What::request;
    std::vector<std::uint8_t> bytes;  // as on the line, damage included
    bool damaged = false;             // a bit flipped on the line: its CRC cannot check
    std::size_t flipped = 0;          // damaged: the byte whose bit flipped
};

// Calls `on_chunk` for every chunk in time order. Chunks carry the time their last byte
// was handed over, like `rtuscope sniff -w` records them. `on_sent`, when given, hears of
// every frame and run of junk or noise as it goes on the line.
TrafficStats generate_traffic(const TrafficOptions& options,
                              const std::function<void(const Chunk&)>& on_chunk,
                              const std::function<void(const SentFrame&)>& on_sent = {});

// A 16550 UART's receive FIFO: the bytes it is given, each at the time it ended on the
// line, handed over at its trigger level (14 bytes) when the last of them ends, or once
// the line has been quiet for 4 characters (its receive timeout) after the last.
class UartFifo {
  public:
    UartFifo(std::uint32_t baud, std::function<void(const Chunk&)> out);
    void byte(std::uint8_t b, Nanos end);
    void finish();  // what it still holds, handed over at the timeout

  private:
    void flush(Nanos at);
    static constexpr std::size_t kTrigger = 14;
    Nanos timeout_;
    std::function<void(const Chunk&)> out_;
    Chunk chunk_;
    Nanos last_end_ = 0;
};

// The header of the traffic's native capture.
std::string capture_header(const TrafficOptions& options);

// The traffic held in memory (tests, micro-benchmarks; rtuscope_bench_gen streams it to
// files instead): as a native capture and as the bytes alone.
struct TrafficInMemory {
    std::string capture;
    std::string raw;
    TrafficStats stats;
};
TrafficInMemory traffic_in_memory(const TrafficOptions& options,
                                  const std::function<void(const SentFrame&)>& on_sent = {});

// `count` bytes of garbage, uniform and the same for a seed on every platform: a line at
// the wrong speed or a dump of noise, where every byte starts a search for a frame.
std::vector<std::uint8_t> garbage(std::uint64_t count, std::uint64_t seed);

// Calls `on_chunk` for each of those bytes as a logic analyser exports them: a chunk of
// its own, back to back with the one before at `baud` (8N1).
void garbage_per_byte(const std::vector<std::uint8_t>& bytes, std::uint32_t baud,
                      const std::function<void(const Chunk&)>& on_chunk);

}  // namespace rtuscope::bench
