#include "traffic.hpp"

#include <algorithm>
#include <optional>
#include <utility>
#include <vector>

#include "framing/crc.hpp"
#include "input/capture_writer.hpp"
#include "util/time.hpp"

namespace rtuscope::bench {
namespace {

using Bytes = std::vector<std::uint8_t>;

// When the generated traffic starts: 2025-11-22 08:00 UTC.
constexpr Nanos kStart = Nanos{1763798400} * kNanosPerSecond;

constexpr Nanos char_time_8n1(std::uint32_t baud) {
    return 10 * kNanosPerSecond / baud;
}

// splitmix64: tiny, fast, and the same sequence everywhere.
class Rng {
  public:
    explicit Rng(std::uint64_t seed) : state_(seed) {}
    std::uint64_t next() {
        std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ULL);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
        return z ^ (z >> 31);
    }
    // Uniform in [lo, hi].
    std::uint32_t range(std::uint32_t lo, std::uint32_t hi) {
        return lo + static_cast<std::uint32_t>(next() % (std::uint64_t{hi} - lo + 1));
    }
    // True with probability per_mille / 1000.
    bool chance(std::uint32_t per_mille) { return next() % 1000 < per_mille; }
    std::uint8_t byte() { return static_cast<std::uint8_t>(next()); }

  private:
    std::uint64_t state_;
};

void put16(Bytes& b, std::uint32_t v) {
    b.push_back(static_cast<std::uint8_t>(v >> 8));
    b.push_back(static_cast<std::uint8_t>(v));
}

Bytes with_crc(Bytes b) {
    const std::uint16_t crc = crc16_modbus(b);
    b.push_back(static_cast<std::uint8_t>(crc & 0xFFU));
    b.push_back(static_cast<std::uint8_t>(crc >> 8));
    return b;
}

Bytes exception(std::uint8_t slave, std::uint8_t fc, std::uint8_t code) {
    return with_crc({slave, static_cast<std::uint8_t>(fc | 0x80U), code});
}

Bytes read_answer(std::uint8_t slave, std::uint8_t fc, std::size_t data_bytes, Rng& rng) {
    Bytes b{slave, fc, static_cast<std::uint8_t>(data_bytes)};
    for (std::size_t i = 0; i < data_bytes; ++i) b.push_back(rng.byte());
    return with_crc(std::move(b));
}

struct Transaction {
    Bytes request;
    Bytes answer;          // empty: no answer
    Nanos turnaround = 0;  // request end to answer start
};

// A standard device: FC01/02/03/04/05/06/0F/10 as the spec has them, 2 % exceptions.
Transaction standard(std::uint8_t slave, Rng& rng, Nanos t35) {
    static constexpr std::uint8_t kCodes[] = {0x01, 0x02, 0x03, 0x03, 0x03, 0x04,
                                              0x04, 0x05, 0x06, 0x0F, 0x10};
    const std::uint8_t fc = kCodes[rng.range(0, sizeof kCodes - 1)];
    Transaction t;
    t.turnaround = t35 + rng.range(0, 4'000'000);
    const std::uint32_t address = rng.range(0, 999);
    Bytes req{slave, fc};
    put16(req, address);
    switch (fc) {
        case 0x01:
        case 0x02: {
            const std::uint32_t qty = rng.range(1, 64);
            put16(req, qty);
            t.answer = read_answer(slave, fc, (qty + 7) / 8, rng);
            break;
        }
        case 0x03:
        case 0x04: {
            const std::uint32_t qty = rng.chance(50) ? rng.range(33, 125) : rng.range(1, 32);
            put16(req, qty);
            t.answer = read_answer(slave, fc, 2 * qty, rng);
            break;
        }
        case 0x05:
        case 0x06:
            put16(req, fc == 0x05 ? (rng.chance(500) ? 0xFF00U : 0) : rng.range(0, 0xFFFF));
            t.answer = with_crc(req);
            break;
        case 0x0F:
        case 0x10: {
            const std::uint32_t qty = rng.range(1, fc == 0x0F ? 64 : 16);
            const std::uint32_t n = fc == 0x0F ? (qty + 7) / 8 : 2 * qty;
            put16(req, qty);
            req.push_back(static_cast<std::uint8_t>(n));
            for (std::uint32_t i = 0; i < n; ++i) req.push_back(rng.byte());
            Bytes ans{slave, fc};
            put16(ans, address);
            put16(ans, qty);
            t.answer = with_crc(std::move(ans));
            break;
        }
        default:
            break;
    }
    t.request = with_crc(std::move(req));
    if (rng.chance(20)) t.answer = exception(slave, fc, static_cast<std::uint8_t>(rng.range(1, 4)));
    return t;
}

// The seed devices at 1-4, with the quirks of src/sim/devices.cpp and profiles/*.toml.
Transaction seed_device(std::uint8_t slave, Rng& rng, Nanos t35) {
    Transaction t;
    t.turnaround = t35 + rng.range(0, 4'000'000);
    Bytes req{slave};
    switch (slave) {
        case 1: {  // zb-uvi485: one register whatever is asked; FC04/FC05 writes echoed
            const std::uint32_t pick = rng.range(0, 9);
            if (pick < 8) {
                req.push_back(0x03);
                put16(req, 0x0000);
                put16(req, rng.range(1, 2));
                t.answer = read_answer(slave, 0x03, 2, rng);
            } else {
                req.push_back(pick == 8 ? 0x04 : 0x05);
                put16(req, pick == 8 ? 0x0015 : 0x0020);
                put16(req, pick == 8 ? rng.range(0, 0xFF) : rng.range(0, 15));
                t.answer = with_crc(req);
            }
            break;
        }
        case 2: {  // sensor-analyser: 18 registers per channel, FC03 only
            if (rng.chance(30)) {
                req.push_back(0x04);
                put16(req, 0);
                put16(req, 2);
                t.answer = exception(slave, 0x04, 0x01);
                break;
            }
            const std::uint32_t qty = rng.range(1, 18);
            req.push_back(0x03);
            put16(req, rng.range(0, 17) * 100);
            put16(req, qty);
            t.answer = read_answer(slave, 0x03, 2 * qty, rng);
            break;
        }
        case 3: {  // pdu485: FC03/06/10, at most 100 registers, 0x1D of them
            const std::uint32_t pick = rng.range(0, 9);
            if (pick < 7) {
                const std::uint32_t start = rng.range(0, 0x1C);
                const bool too_many = rng.chance(10);
                const std::uint32_t qty = too_many ? 120 : rng.range(1, 0x1D - start);
                req.push_back(0x03);
                put16(req, start);
                put16(req, qty);
                t.answer = too_many ? exception(slave, 0x03, 0x03)
                                    : read_answer(slave, 0x03, 2 * qty, rng);
            } else if (pick < 9) {
                req.push_back(0x06);
                put16(req, rng.range(0, 0x1C));
                put16(req, rng.range(0, 0xFFFF));
                t.answer = with_crc(req);
            } else {
                req.push_back(0x10);
                put16(req, 0x0004);
                put16(req, 2);
                req.push_back(4);
                for (int i = 0; i < 4; ++i) req.push_back(rng.byte());
                Bytes ans{slave, 0x10};
                put16(ans, 0x0004);
                put16(ans, 2);
                t.answer = with_crc(std::move(ans));
            }
            break;
        }
        default: {  // zyi-relay: slow (0.15-0.25 s) answers; FC03 and FC06
            t.turnaround = rng.range(150'000'000, 250'000'000);
            if (rng.chance(700)) {
                const std::uint32_t start = rng.range(0, 0x0E);
                const std::uint32_t qty = rng.range(1, 0x0F - start);
                req.push_back(0x03);
                put16(req, start);
                put16(req, qty);
                t.answer = read_answer(slave, 0x03, 2 * qty, rng);
            } else {
                req.push_back(0x06);
                put16(req, rng.range(1, 0x0E));
                put16(req, rng.range(0, 1));
                t.answer = with_crc(req);
            }
            break;
        }
    }
    t.request = with_crc(std::move(req));
    return t;
}

// A USB serial adapter: bytes are handed over in batches of at most 64 bytes, when the
// latency timer (16 ms by default, 1 ms in low-latency mode) runs out after the first
// byte of a batch. So an answer sometimes arrives in the same chunk as its request.
// Per byte, it is a logic analyser instead: every byte alone, when it ended. A UART's
// FIFO hands its bytes over at its trigger level or after its receive timeout.
class Adapter {
  public:
    Adapter(Rng& rng, const std::function<void(const Chunk&)>& out, TrafficStats& stats,
            const TrafficOptions& options)
        : rng_(rng),
          out_(out),
          stats_(stats),
          per_byte_(options.per_byte),
          usb_timer_(options.usb_timer) {
        if (options.uart_fifo) {
            fifo_.emplace(options.baud, [this](const Chunk& c) {
                chunk_ = c;
                flush(c.time);
            });
        }
    }

    void byte(std::uint8_t b, Nanos end) {
        if (per_byte_) {
            chunk_.bytes.push_back(b);
            flush(end);
            return;
        }
        if (fifo_) {
            fifo_->byte(b, end);
            return;
        }
        if (!chunk_.bytes.empty() && end > deadline_) flush(deadline_);
        if (chunk_.bytes.empty()) {
            Nanos window = usb_timer_;
            if (window == 0) {
                const std::uint32_t pick = rng_.range(0, 9);
                window = pick < 6   ? 16'000'000
                         : pick < 8 ? 1'000'000
                                    : rng_.range(2, 15) * 1'000'000LL;
            }
            deadline_ = end + window;
        }
        chunk_.bytes.push_back(b);
        if (chunk_.bytes.size() == 64) flush(end);
    }
    void finish() {
        if (fifo_) fifo_->finish();
        if (!chunk_.bytes.empty()) flush(deadline_);
    }

  private:
    void flush(Nanos at) {
        chunk_.time = at;
        out_(chunk_);
        ++stats_.chunks;
        stats_.bytes += chunk_.bytes.size();
        chunk_.bytes.clear();
    }

    Rng& rng_;
    const std::function<void(const Chunk&)>& out_;
    TrafficStats& stats_;
    bool per_byte_;
    Nanos usb_timer_;
    std::optional<UartFifo> fifo_;
    Chunk chunk_;
    Nanos deadline_ = 0;
};

// One transaction of TrafficOptions::all_slaves_functions: the n-th of the rounds over
// every slave and function. Each request has the 8 bytes of a read, whatever its function;
// the exception answers it after t3.5 plus up to 18 ms.
Transaction all_slaves(std::uint64_t n, std::uint32_t functions, Rng& rng, Nanos t35) {
    const auto slave = static_cast<std::uint8_t>(1 + (n / functions) % 247);
    const auto fc = static_cast<std::uint8_t>(1 + n % functions);
    Transaction t;
    t.request = with_crc({slave, fc, 0x00, 0x00, 0x00, 0x01});
    t.answer = exception(slave, fc, 0x01);
    t.turnaround = t35 + rng.range(0, 18'000'000);
    return t;
}

}  // namespace

TrafficStats generate_traffic(const TrafficOptions& options,
                              const std::function<void(const Chunk&)>& on_chunk,
                              const std::function<void(const SentFrame&)>& on_sent) {
    TrafficStats stats;
    Rng rng(options.seed);
    Adapter adapter(rng, on_chunk, stats, options);
    const Nanos char_time = char_time_8n1(options.baud);
    // t3.5 as the spec has it, fixed at 1.75 ms above 19200 baud.
    const Nanos t35 = options.baud > 19200 ? 1'750'000 : 35 * char_time / 10;
    Nanos now = kStart;

    auto send = [&](const Bytes& frame, SentFrame::What what, bool damaged = false,
                    std::size_t flipped = 0) {
        for (std::size_t i = 0; i < frame.size(); ++i) {
            if (i != 0) now += options.char_pause;
            now += char_time;
            adapter.byte(frame[i], now);
        }
        if (on_sent) on_sent({what, frame, damaged, flipped});
    };

    for (std::uint64_t n = 0; stats.frames < options.frames; ++n) {
        Transaction t;
        const std::uint32_t pick = rng.range(0, 99);
        if (options.all_slaves_functions != 0) {
            t = all_slaves(n, options.all_slaves_functions, rng, t35);
        } else if (pick < 40) {
            t = seed_device(static_cast<std::uint8_t>(1 + pick / 10), rng, t35);
        } else {
            t = standard(static_cast<std::uint8_t>(rng.range(5, 24)), rng, t35);
        }
        if (rng.chance(2)) {  // a broadcast write: never answered
            t.request = with_crc({0x00, 0x06, 0x00, 0x01, rng.byte(), rng.byte()});
            t.answer.clear();
        }
        if (rng.chance(10)) t.answer.clear();  // the slave does not answer
        // A bit flipped on the line, in either frame.
        auto any_byte = [&](const Bytes& b) {
            return rng.range(0, static_cast<std::uint32_t>(b.size() - 1));
        };
        const bool request_damaged = rng.chance(options.damaged_per_mille);
        std::size_t request_flipped = 0;
        if (request_damaged) {
            request_flipped = any_byte(t.request);
            t.request[request_flipped] ^= 0x10;
        }
        const bool answer_damaged = !t.answer.empty() && rng.chance(options.damaged_per_mille);
        std::size_t answer_flipped = 0;
        if (answer_damaged) {
            answer_flipped = any_byte(t.answer);
            t.answer[answer_flipped] ^= 0x04;
        }

        send(t.request, SentFrame::What::request, request_damaged, request_flipped);
        ++stats.frames;
        if (!t.answer.empty()) {
            now += t.turnaround;
            send(t.answer, SentFrame::What::answer, answer_damaged, answer_flipped);
            ++stats.frames;
            // The slave's RS-485 driver switching off leaves a junk byte behind.
            if (rng.chance(3)) {
                send({rng.chance(500) ? std::uint8_t{0x00} : std::uint8_t{0xFF}},
                     SentFrame::What::junk);
            }
        }
        if (rng.chance(2)) {  // line noise between transactions
            now += t35;
            Bytes noise(rng.range(1, 4));
            for (auto& b : noise) b = rng.byte();
            send(noise, SentFrame::What::noise);
        }
        // The master polls again after t3.5 plus its own processing time.
        now += t35 + rng.range(0, options.baud > 19200 ? 1'000'000 : 10'000'000);
    }
    adapter.finish();
    return stats;
}

UartFifo::UartFifo(std::uint32_t baud, std::function<void(const Chunk&)> out)
    : timeout_(4 * char_time_8n1(baud)), out_(std::move(out)) {}

void UartFifo::byte(std::uint8_t b, Nanos end) {
    if (!chunk_.bytes.empty() && end > last_end_ + timeout_) flush(last_end_ + timeout_);
    chunk_.bytes.push_back(b);
    last_end_ = end;
    if (chunk_.bytes.size() == kTrigger) flush(end);
}

void UartFifo::finish() {
    if (!chunk_.bytes.empty()) flush(last_end_ + timeout_);
}

void UartFifo::flush(Nanos at) {
    chunk_.time = at;
    out_(chunk_);
    chunk_.bytes.clear();
}

std::string capture_header(const TrafficOptions& options) {
    SourceInfo header;
    header.line = LineSettings{.baud = options.baud};
    return rtuscope::capture_header(header);
}

TrafficInMemory traffic_in_memory(const TrafficOptions& options,
                                  const std::function<void(const SentFrame&)>& on_sent) {
    TrafficInMemory out;
    out.capture = capture_header(options);
    out.stats = generate_traffic(
        options,
        [&](const Chunk& c) {
            out.capture += capture_line(c);
            out.raw.append(c.bytes.begin(), c.bytes.end());
        },
        on_sent);
    return out;
}

std::vector<std::uint8_t> garbage(std::uint64_t count, std::uint64_t seed) {
    Rng rng(seed);
    std::vector<std::uint8_t> bytes(count);
    for (auto& b : bytes) b = rng.byte();
    return bytes;
}

void garbage_per_byte(const std::vector<std::uint8_t>& bytes, std::uint32_t baud,
                      const std::function<void(const Chunk&)>& on_chunk) {
    Chunk chunk;
    chunk.time = kStart;
    for (const std::uint8_t b : bytes) {
        chunk.time += char_time_8n1(baud);
        chunk.bytes.assign(1, b);
        on_chunk(chunk);
    }
}

}  // namespace rtuscope::bench
