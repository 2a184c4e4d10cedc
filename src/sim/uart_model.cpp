// UartResampler: the wire's characters as bit streams, sampled by a 16550-style receiver
// (see uart_model.hpp).
#include "sim/uart_model.hpp"

#include <bit>

namespace rtuscope::sim {

namespace {

// The parity bit a transmitter sends after `data` (already masked to its data bits).
bool parity_bit(std::uint32_t data, char parity) {
    const bool odd_ones = (std::popcount(data) & 1) != 0;
    return parity == 'E' ? odd_ones : !odd_ones;
}

std::uint32_t data_mask(const LineSettings& line) {
    return (1U << line.data_bits) - 1U;
}

}  // namespace

UartResampler::UartResampler(LineSettings wire, LineSettings receiver, Nanos listen_from)
    : wire_(wire),
      receiver_(receiver),
      wire_bits_(wire.bits_per_char()),
      stop_sample_(1U + receiver.data_bits + (receiver.parity == 'N' ? 0U : 1U)),
      den_(2 * static_cast<std::int64_t>(wire.baud) * receiver.baud),
      wire_bit_(2 * kNanosPerSecond * receiver.baud),
      half_bit_(kNanosPerSecond * wire.baud),
      wire_char_ns_((static_cast<Nanos>(wire_bits_) * kNanosPerSecond + wire.baud - 1) / wire.baud),
      // Just before `listen_from`, so that an edge exactly at it counts.
      last_(listen_from == kNoTime ? Instant{kNoTime, 0} : Instant{listen_from - 1, den_ - 1}) {}

void UartResampler::send(Nanos start, std::uint8_t byte) {
    const std::uint32_t data = byte & data_mask(wire_);
    std::uint32_t levels = data << 1U;  // bit 0, the start bit, is 0
    unsigned bit = 1U + wire_.data_bits;
    if (wire_.parity != 'N') {
        if (parity_bit(data, wire_.parity)) levels |= 1U << bit;
        ++bit;
    }
    for (unsigned s = 0; s < wire_.stop_bits; ++s) levels |= 1U << bit++;
    chars_.push_back({start, levels});
}

UartResampler::Instant UartResampler::plus(Instant t, std::int64_t units) const {
    t.frac += units;
    t.ns += t.frac / den_;
    t.frac %= den_;
    return t;
}

UartResampler::Instant UartResampler::sample_time(const Edge& edge, unsigned bit) const {
    return plus(edge.at, (2 * static_cast<std::int64_t>(bit) + 1) * half_bit_);
}

bool UartResampler::ended_by(const WireChar& c, Instant t) const {
    const Instant end = plus({c.start, 0}, static_cast<std::int64_t>(wire_bits_) * wire_bit_);
    return !(t < end);
}

std::optional<UartResampler::Edge> UartResampler::next_edge(Instant after) const {
    for (std::size_t i = 0; i < chars_.size(); ++i) {
        const WireChar& c = chars_[i];
        if (ended_by(c, after)) continue;
        // Bit 0 (the start bit) always begins with a fall: the line before it is idle or
        // the stop bit of the character before.
        bool before = true;
        for (unsigned b = 0; b < wire_bits_; ++b) {
            const bool level = ((c.levels >> b) & 1U) != 0;
            if (before && !level) {
                const Instant at = plus({c.start, 0}, static_cast<std::int64_t>(b) * wire_bit_);
                if (after < at) return Edge{at, i};
            }
            before = level;
        }
    }
    return std::nullopt;
}

bool UartResampler::level_at(Instant t, std::size_t& index) const {
    while (index + 1 < chars_.size() && chars_[index + 1].start <= t.ns) ++index;
    if (index >= chars_.size() || chars_[index].start > t.ns) return true;
    const WireChar& c = chars_[index];
    const Nanos elapsed = t.ns - c.start;
    // Far beyond the character (and the product below would be needlessly large): idle.
    if (elapsed > wire_char_ns_) return true;
    // Wire bits since the start: (elapsed + frac / den) * baud / 1e9, where
    // frac / den * baud = frac / (2 * receiver baud); flooring that part first does not
    // change the whole floor.
    const std::int64_t scaled =
        elapsed * wire_.baud + t.frac / (2 * static_cast<std::int64_t>(receiver_.baud));
    const auto bit = static_cast<std::uint64_t>(scaled / kNanosPerSecond);
    if (bit >= wire_bits_) return true;
    return ((c.levels >> bit) & 1U) != 0;
}

Received UartResampler::read_char(const Edge& edge) const {
    std::size_t index = edge.index;
    Received r;
    std::uint32_t data = 0;
    for (unsigned b = 0; b < receiver_.data_bits; ++b) {
        if (level_at(sample_time(edge, 1 + b), index)) data |= 1U << b;
    }
    bool any_one = data != 0;
    if (receiver_.parity != 'N') {
        const bool parity = level_at(sample_time(edge, 1U + receiver_.data_bits), index);
        r.parity_error = parity != parity_bit(data, receiver_.parity);
        any_one = any_one || parity;
    }
    const Instant stop = sample_time(edge, stop_sample_);
    r.framing_error = !level_at(stop, index);
    r.line_break = r.framing_error && !any_one;
    r.byte = static_cast<std::uint8_t>(data);
    r.time = stop.ns + (stop.frac > 0 ? 1 : 0);
    return r;
}

void UartResampler::take_until(Nanos now, std::vector<Received>& out) {
    const Instant limit{now, 0};
    for (;;) {
        const auto edge = next_edge(last_);
        if (!edge) break;
        const Instant start_sample = sample_time(*edge, 0);
        if (limit < start_sample) break;
        std::size_t index = edge->index;
        if (level_at(start_sample, index)) {
            last_ = start_sample;  // a glitch, not a start bit
        } else {
            const Instant stop = sample_time(*edge, stop_sample_);
            if (limit < stop) break;
            out.push_back(read_char(*edge));
            last_ = stop;
        }
        while (!chars_.empty() && ended_by(chars_.front(), last_)) chars_.pop_front();
    }
}

std::optional<Nanos> UartResampler::next_completion() const {
    Instant last = last_;
    for (;;) {
        const auto edge = next_edge(last);
        if (!edge) return std::nullopt;
        const Instant start_sample = sample_time(*edge, 0);
        std::size_t index = edge->index;
        if (level_at(start_sample, index)) {
            last = start_sample;
            continue;
        }
        const Instant stop = sample_time(*edge, stop_sample_);
        return stop.ns + (stop.frac > 0 ? 1 : 0);
    }
}

}  // namespace rtuscope::sim
