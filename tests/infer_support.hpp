// Captures of devices whose registers are known: a master polling a device description in
// blocks, each register's value a function of time. What `profiles infer` is tested
// against (test_infer.cpp, infer_accuracy.cpp): the types it finds are compared with the
// description's. Deterministic: the same description gives the same capture.
#pragma once

#include <bit>
#include <cmath>
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "framing/crc.hpp"
#include "infer/poll_map.hpp"
#include "infer/scoring.hpp"
#include "input/capture_writer.hpp"
#include "profiles/profile.hpp"

namespace rtuscope::test {

struct SimRegister {
    std::string table = "holding";
    std::uint16_t address = 0;
    ValueType type = ValueType::u16;
    WordOrder order = WordOrder::abcd;
    // The value at poll `i`, `t` seconds into the capture.
    std::function<double(int i, double t)> value;
    bool written = false;  // the master also writes it (FC06/FC16/FC05)
};

struct SimBlock {
    std::uint8_t function = 3;
    std::uint16_t start = 0;
    std::uint16_t count = 1;
};

struct SimDevice {
    std::string name;
    std::uint8_t slave = 1;
    std::vector<SimRegister> registers;
    std::vector<SimBlock> blocks;  // polled in this order every cycle
};

// The words a register's value takes on the wire, in its word order.
inline std::vector<std::uint16_t> sim_words(const SimRegister& r, double value) {
    const auto u16 = [](double v) { return static_cast<std::uint16_t>(static_cast<std::int64_t>(std::llround(v))); };
    std::uint32_t bits = 0;
    switch (r.type) {
        case ValueType::u32:
        case ValueType::i32:
            bits = static_cast<std::uint32_t>(static_cast<std::int64_t>(std::llround(value)));
            break;
        case ValueType::f32:
            bits = std::bit_cast<std::uint32_t>(static_cast<float>(value));
            break;
        default:
            return {u16(value)};
    }
    const auto high = static_cast<std::uint16_t>(bits >> 16);
    const auto low = static_cast<std::uint16_t>(bits & 0xFFFF);
    return r.order == WordOrder::cdab ? std::vector<std::uint16_t>{low, high}
                                      : std::vector<std::uint16_t>{high, low};
}

inline std::string sim_table_of(std::uint8_t function) {
    switch (function) {
        case 1: return "coil";
        case 2: return "discrete";
        case 4: return "input";
        default: return "holding";
    }
}

// `cycles` polls of every block, `period` seconds apart, answered 5 ms after each request;
// every tenth cycle writes each written register (its value then) as well. A native
// capture at 9600 8N1.
inline std::string sim_capture(const SimDevice& device, int cycles, double period = 1.0) {
    SourceInfo header;
    header.line = LineSettings{};
    std::string text = capture_header(header);
    const Nanos base = 1'763'798'400LL * 1'000'000'000LL;
    const Nanos char_time = LineSettings{}.char_time();
    Nanos now = base;
    const auto send = [&](std::vector<std::uint8_t> bytes) {
        const std::uint16_t crc = crc16_modbus(bytes);
        bytes.push_back(static_cast<std::uint8_t>(crc & 0xFF));
        bytes.push_back(static_cast<std::uint8_t>(crc >> 8));
        now += char_time * static_cast<Nanos>(bytes.size());
        Chunk chunk;
        chunk.time = now;
        chunk.bytes = std::move(bytes);
        text += capture_line(chunk);
        now += 5'000'000;
    };
    const auto put16 = [](std::vector<std::uint8_t>& b, std::uint16_t v) {
        b.push_back(static_cast<std::uint8_t>(v >> 8));
        b.push_back(static_cast<std::uint8_t>(v & 0xFF));
    };
    for (int i = 0; i < cycles; ++i) {
        now = base + static_cast<Nanos>(std::llround(i * period * 1e9));
        const double t = i * period;
        std::map<std::pair<std::string, std::uint16_t>, std::uint16_t> words;
        for (const SimRegister& r : device.registers) {
            const std::vector<std::uint16_t> w = sim_words(r, r.value(i, t));
            for (std::size_t k = 0; k < w.size(); ++k) words[{r.table, static_cast<std::uint16_t>(r.address + k)}] = w[k];
        }
        for (const SimBlock& b : device.blocks) {
            std::vector<std::uint8_t> request{device.slave, b.function};
            put16(request, b.start);
            put16(request, b.count);
            send(request);
            std::vector<std::uint8_t> answer{device.slave, b.function};
            const std::string table = sim_table_of(b.function);
            if (b.function <= 2) {
                std::vector<std::uint8_t> data((b.count + 7U) / 8U, 0);
                for (unsigned k = 0; k < b.count; ++k) {
                    auto it = words.find({table, static_cast<std::uint16_t>(b.start + k)});
                    if (it != words.end() && it->second != 0) data[k / 8] |= static_cast<std::uint8_t>(1U << (k % 8));
                }
                answer.push_back(static_cast<std::uint8_t>(data.size()));
                answer.insert(answer.end(), data.begin(), data.end());
            } else {
                answer.push_back(static_cast<std::uint8_t>(2 * b.count));
                for (unsigned k = 0; k < b.count; ++k) {
                    auto it = words.find({table, static_cast<std::uint16_t>(b.start + k)});
                    put16(answer, it == words.end() ? 0 : it->second);
                }
            }
            send(answer);
        }
        if (i % 10 != 0) continue;
        for (const SimRegister& r : device.registers) {
            if (!r.written) continue;
            const std::vector<std::uint16_t> w = sim_words(r, r.value(i, t));
            std::vector<std::uint8_t> request{device.slave};
            if (r.table == "coil") {
                request.push_back(5);
                put16(request, r.address);
                put16(request, w[0] != 0 ? 0xFF00 : 0x0000);
            } else if (w.size() == 1) {
                request.push_back(6);
                put16(request, r.address);
                put16(request, w[0]);
            } else {
                request.push_back(0x10);
                put16(request, r.address);
                put16(request, static_cast<std::uint16_t>(w.size()));
                request.push_back(static_cast<std::uint8_t>(2 * w.size()));
                for (std::uint16_t word : w) put16(request, word);
            }
            send(request);
            std::vector<std::uint8_t> echo(request.begin(), request.begin() + 6);
            send(echo);
        }
    }
    return text;
}

// A status word whose bits 0 and `other` toggle one at a time (a Gray code), every 4 polls.
inline double sim_gray_bits(int i, unsigned other) {
    const int k = (i / 4) % 4;
    const int gray = k ^ (k >> 1);
    return (gray & 1) + ((gray >> 1) & 1) * static_cast<double>(1U << other);
}

// The registers of a profile in the four standard tables (strings left out: their
// characters are constants) as a device polled in blocks of at most `block` registers,
// each value moving as its type lets it show: u16 drifting, i16 across zero, 32-bit
// integers carrying into the high word, floats drifting, enums and bit fields stepping.
inline SimDevice sim_device_of(const Profile& profile, std::uint8_t slave, std::uint16_t block = 60) {
    SimDevice d;
    d.name = profile.name;
    d.slave = slave;
    for (const Register& r : profile.registers) {
        if (r.type == ValueType::string || r.length > 2) continue;
        const std::uint8_t function = r.table == "holding" ? 3 : r.table == "input" ? 4
                                      : r.table == "coil" ? 1 : r.table == "discrete" ? 2 : 0;
        if (function == 0) continue;
        SimRegister s;
        s.table = r.table;
        s.address = r.address;
        s.type = r.type;
        s.order = r.word_order;
        const double phase = r.address % 7;
        std::vector<double> labels;
        for (const auto& [raw, name] : r.labels) labels.push_back(raw);
        if (is_bit_table(r.table)) {
            s.value = [phase](int i, double) { return ((i + static_cast<int>(phase)) / 3) % 2; };
        } else {
            switch (r.type) {
                case ValueType::i16:
                    s.value = [phase](int, double t) { return 80 * std::sin(t / 8 + phase); };
                    break;
                case ValueType::u32:
                    s.value = [phase](int i, double) { return 65'000 + 40 * i + phase; };
                    break;
                case ValueType::i32:
                    s.value = [phase](int i, double) { return -1500 + 37 * i + phase; };
                    break;
                case ValueType::f32:
                    s.value = [phase](int, double t) { return 230 + 2 * std::sin(t / 9 + phase); };
                    break;
                case ValueType::enumeration:
                    if (labels.size() < 2) labels = {0, 1, 2};
                    s.value = [labels](int i, double) { return labels[static_cast<std::size_t>(i / 4) % labels.size()]; };
                    break;
                case ValueType::bits:
                    s.value = [](int i, double) { return sim_gray_bits(i, 2); };
                    break;
                default:
                    s.value = [phase](int, double t) { return 1200 + 300 * std::sin(t / 11 + phase); };
                    break;
            }
        }
        d.registers.push_back(std::move(s));
        // Blocks: consecutive registers of a table, at most `block` long.
        const std::uint16_t end = static_cast<std::uint16_t>(r.address + r.length);
        if (!d.blocks.empty() && d.blocks.back().function == function &&
            r.address >= d.blocks.back().start &&
            end - d.blocks.back().start <= block) {
            d.blocks.back().count = static_cast<std::uint16_t>(std::max<int>(d.blocks.back().count, end - d.blocks.back().start));
        } else {
            d.blocks.push_back({function, r.address, r.length});
        }
    }
    return d;
}

// How the guesses score against the description: the register typed as described, typed
// otherwise but with the described type among the alternatives, or typed wrong (or not
// found at its address).
struct InferScore {
    int right = 0;
    int ambiguous_accepted = 0;
    int wrong = 0;
    std::vector<std::string> wrong_names;
};

inline infer::Table sim_infer_table(const std::string& table) {
    if (table == "coil") return infer::Table::coil;
    if (table == "discrete") return infer::Table::discrete;
    if (table == "input") return infer::Table::input;
    return infer::Table::holding;
}

inline InferScore score_guess(const SimDevice& device, const infer::DeviceGuess& guess) {
    InferScore score;
    for (const SimRegister& r : device.registers) {
        const infer::RegisterGuess* g = nullptr;
        for (const infer::RegisterGuess& candidate : guess.registers) {
            if (candidate.table == sim_infer_table(r.table) && candidate.address == r.address) g = &candidate;
        }
        // Coils and discrete inputs are u16 (0/1) or enum in a profile, either right.
        const ValueType type = is_bit_table(r.table) ? ValueType::u16 : r.type;
        if (g != nullptr && g->type == type && (!is_multi_register(type) || g->word_order == r.order)) {
            ++score.right;
        } else if (g != nullptr && g->accepts(type, r.order)) {
            ++score.ambiguous_accepted;
        } else {
            ++score.wrong;
            score.wrong_names.push_back(fmt::format("{} {} 0x{:04X} {} as {}", device.name, r.table, r.address,
                                                    infer::reading_name(type, r.order),
                                                    g == nullptr ? "missing" : infer::reading_name(g->type, g->word_order)));
        }
    }
    return score;
}

// The test-only energy meter: f32 in CDAB, u32 counters carrying, signed temperatures
// across zero, a status bit field, a mode enum.
inline SimDevice energy_meter() {
    SimDevice d;
    d.name = "energy-meter";
    d.slave = 7;
    const auto reg = [&](std::string table, std::uint16_t address, ValueType type, WordOrder order,
                         std::function<double(int, double)> value, bool written = false) {
        d.registers.push_back({std::move(table), address, type, order, std::move(value), written});
    };
    reg("input", 0x0000, ValueType::f32, WordOrder::cdab, [](int, double t) { return 230 + 1.5 * std::sin(t / 20); });
    reg("input", 0x0002, ValueType::f32, WordOrder::cdab, [](int, double t) { return 4.2 + 0.8 * std::sin(t / 7); });
    reg("input", 0x0004, ValueType::f32, WordOrder::cdab, [](int, double t) { return 960 + 180 * std::sin(t / 7); });
    reg("input", 0x0006, ValueType::f32, WordOrder::cdab, [](int, double) { return 50.0; });
    reg("holding", 0x0100, ValueType::u32, WordOrder::abcd, [](int i, double) { return 131'000 + 97.0 * i; });
    reg("holding", 0x0102, ValueType::u32, WordOrder::cdab, [](int i, double) { return 65'400 + 13.0 * i; });
    reg("holding", 0x0200, ValueType::i16, WordOrder::abcd, [](int, double t) { return 35 * std::sin(t / 10) + 5; });
    reg("holding", 0x0201, ValueType::i16, WordOrder::abcd, [](int, double t) { return -120 + 150 * std::sin(t / 13); });
    reg("holding", 0x0202, ValueType::bits, WordOrder::abcd, [](int i, double) { return sim_gray_bits(i, 3); });
    reg("holding", 0x0203, ValueType::enumeration, WordOrder::abcd, [](int i, double) { return (i / 6) % 3; }, true);
    reg("holding", 0x0204, ValueType::u16, WordOrder::abcd, [](int, double) { return 1; });
    d.blocks = {{4, 0x0000, 8}, {3, 0x0100, 4}, {3, 0x0200, 5}};
    return d;
}

}  // namespace rtuscope::test
