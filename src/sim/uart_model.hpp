// What a UART receiving at one line setting makes of characters sent at another. Each
// character on the wire is a bit stream (start bit 0, data bits LSB first, the parity bit if
// any, stop bits 1; the line idles at 1), and the receiver is a 16550-style state machine
// sampling it: it waits for a falling edge, checks the start bit at its middle (a 1 there
// was a glitch: it hunts again), samples each data bit, the parity bit and the first stop
// bit at their centres, and hunts for the next falling edge after that stop-bit sample.
// Only the first stop bit is checked, as real UARTs do, so a receiver's stop bits never
// change what it receives. The virtual bus uses it so that a port set to the wrong baud
// rate or format gets the garbage a real adapter would, and `rtuscope detect` can be tested
// end to end.
//
// Times are exact: a time is integer nanoseconds plus a fraction in units of
// 1/(2 * wire baud * receiver baud) ns, in which every wire bit edge and every receiver
// sample point falls on a whole unit.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <optional>
#include <vector>

#include "framing/line_settings.hpp"
#include "util/time.hpp"

namespace rtuscope::sim {

// A character as the receiving UART reports it.
struct Received {
    Nanos time = 0;         // the receiver's first stop-bit sample, rounded up to the nanosecond
    std::uint8_t byte = 0;  // a 7-bit receiver's has the top bit 0
    bool parity_error = false;
    bool framing_error = false;  // the first stop bit sampled 0
    bool line_break = false;     // every bit sampled 0, the stop bit too (a framing error)
    friend bool operator==(const Received&, const Received&) = default;
};

// One receiver listening to one wire, fed characters as they go out and asked, as time
// passes, for what it has received.
class UartResampler {
  public:
    // The receiver starts hunting for a start bit at `listen_from` (a port configured while
    // the line is busy joins mid-stream); kNoTime: at the first character.
    UartResampler(LineSettings wire, LineSettings receiver, Nanos listen_from = kNoTime);

    // A character put on the wire at `start`, in time order. One that starts before the
    // previous one ended cuts it short (the bus's integer character times can run a
    // fraction of a nanosecond ahead of the exact ones).
    void send(Nanos start, std::uint8_t byte);
    // Appends the characters whose stop-bit sample is at or before `now`, in order. Every
    // character that starts before `now` must have been sent: the waveform before `now` is
    // final, and the line after the last character is idle.
    void take_until(Nanos now, std::vector<Received>& out);
    // When the next character completes, from the characters sent so far (a later one can
    // change it); none when the line holds no start bit the receiver has yet to read.
    [[nodiscard]] std::optional<Nanos> next_completion() const;

    [[nodiscard]] const LineSettings& wire() const { return wire_; }
    [[nodiscard]] const LineSettings& receiver() const { return receiver_; }

  private:
    // ns + frac / den_ nanoseconds, 0 <= frac < den_: ordered as the pair (ns, frac).
    struct Instant {
        Nanos ns = 0;
        std::int64_t frac = 0;
        friend bool operator<(const Instant& a, const Instant& b) {
            return a.ns != b.ns ? a.ns < b.ns : a.frac < b.frac;
        }
    };
    struct WireChar {
        Nanos start = 0;
        std::uint32_t levels = 0;  // bit i: the line during the character's bit i
    };
    struct Edge {
        Instant at;
        std::size_t index = 0;  // in chars_
    };

    [[nodiscard]] Instant plus(Instant t, std::int64_t units) const;
    [[nodiscard]] Instant sample_time(const Edge& edge, unsigned bit) const;
    [[nodiscard]] std::optional<Edge> next_edge(Instant after) const;
    // The line at `t`; `index` is a character at or before the one covering `t`, moved on.
    [[nodiscard]] bool level_at(Instant t, std::size_t& index) const;
    [[nodiscard]] Received read_char(const Edge& edge) const;
    [[nodiscard]] bool ended_by(const WireChar& c, Instant t) const;

    LineSettings wire_;
    LineSettings receiver_;
    unsigned wire_bits_;     // bits per character on the wire
    unsigned stop_sample_;   // the receiver's bit index of its first stop bit
    std::int64_t den_;       // fraction units per nanosecond
    std::int64_t wire_bit_;  // one wire bit, in units
    std::int64_t half_bit_;  // half a receiver bit, in units
    Nanos wire_char_ns_;     // a wire character, rounded up to whole ns
    std::deque<WireChar> chars_;
    Instant last_;  // the receiver's last sample: it hunts for an edge after it
};

}  // namespace rtuscope::sim
