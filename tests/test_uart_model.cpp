// The UART model: what a receiver at one baud rate and format makes of characters sent at
// another. Expected results are derived from bit positions. On an 8N1 wire a character
// is 10 bits: position 0 the start bit (0), 1-8 the data bits D0-D7, 9 the stop bit (1);
// the next back-to-back character starts at position 10. A receiver samples its bit j at
// (j + 0.5) of its own bit times after the falling edge it synchronised on.
#include <gtest/gtest.h>

#include <bit>
#include <cstdint>
#include <string>
#include <vector>

#include "framing/line_settings.hpp"
#include "sim/uart_model.hpp"

namespace rtuscope::sim {
namespace {

using Bytes = std::vector<std::uint8_t>;

constexpr Nanos kStart = 1'000'000;

LineSettings line(std::uint32_t baud, const std::string& format) {
    auto parsed = parse_line_format(format);
    EXPECT_TRUE(parsed.ok()) << format;
    LineSettings l = parsed.ok() ? *parsed : LineSettings{};
    l.baud = baud;
    return l;
}

// The bytes sent back to back, each one character time (the bus's integer one) after the
// one before, as the virtual bus sends a frame; everything the receiver makes of them.
std::vector<Received> receive(const LineSettings& wire, const LineSettings& receiver,
                              const Bytes& bytes) {
    UartResampler uart(wire, receiver);
    Nanos t = kStart;
    for (const std::uint8_t b : bytes) {
        uart.send(t, b);
        t += wire.char_time();
    }
    std::vector<Received> out;
    uart.take_until(t + kNanosPerSecond, out);
    return out;
}

Bytes every_byte() {
    Bytes all(256);
    for (std::size_t i = 0; i < all.size(); ++i) all[i] = static_cast<std::uint8_t>(i);
    return all;
}

Received clean(std::uint8_t byte) {
    Received r;
    r.byte = byte;
    return r;
}

// The received characters without their times, for comparing with derived ones.
std::vector<Received> untimed(std::vector<Received> got) {
    for (Received& r : got) r.time = 0;
    return got;
}

bool even_ones(std::uint8_t b) {
    return std::popcount(b) % 2 == 0;
}

TEST(UartModel, SameSettingsReceiveEveryByteUnchanged) {
    for (const char* format :
         {"8N1", "8E1", "8O1", "8N2", "8E2", "8O2", "7N1", "7E1", "7O1", "7N2", "7E2", "7O2"}) {
        for (const std::uint32_t baud : {1200U, 9600U, 115200U}) {
            const LineSettings l = line(baud, format);
            const auto got = receive(l, l, every_byte());
            ASSERT_EQ(got.size(), 256u) << format << " " << baud;
            const std::uint8_t mask = l.data_bits == 7 ? 0x7F : 0xFF;
            for (std::size_t i = 0; i < got.size(); ++i) {
                const auto sent = static_cast<std::uint8_t>(i);
                EXPECT_EQ(untimed({got[i]}), untimed({clean(sent & mask)}))
                    << format << " " << baud << " byte " << i;
            }
        }
    }
}

TEST(UartModel, CompletesAtTheStopBitSample) {
    // 9600 8N1: the stop bit (bit 9) is sampled 9.5 bit times after the start,
    // 9.5e9 / 9600 = 989583.3 ns, rounded up.
    const LineSettings l = line(9600, "8N1");
    const auto got = receive(l, l, {0x42});
    ASSERT_EQ(got.size(), 1u);
    EXPECT_EQ(got[0].time, kStart + 989584);
}

TEST(UartModel, StopBitsOfTheReceiverDoNotMatter) {
    // Only the first stop bit is sampled (bit 9); both wires have a 1 there, and the next
    // start bit is the first fall after it.
    const Bytes all = every_byte();
    const auto one_on_two = receive(line(9600, "8N2"), line(9600, "8N1"), all);
    const auto two_on_one = receive(line(9600, "8N1"), line(9600, "8N2"), all);
    ASSERT_EQ(one_on_two.size(), 256u);
    ASSERT_EQ(two_on_one.size(), 256u);
    for (std::size_t i = 0; i < 256; ++i) {
        EXPECT_EQ(untimed({one_on_two[i]}), untimed({clean(all[i])})) << i;
        EXPECT_EQ(untimed({two_on_one[i]}), untimed({clean(all[i])})) << i;
    }
}

TEST(UartModel, NoParityReceiverTakesTheParityBitForTheStopBit) {
    // 8E1 wire: bit 9 is the parity bit, bit 10 the stop bit. The 8N1 receiver reads D0-D7
    // unchanged and samples bit 9 as its stop bit: a framing error exactly when the even
    // parity bit is 0 (an even number of ones); for 0x00 every sample is 0: a break. Its
    // next fall is the next start bit (bit 10 is 1), so it stays in step.
    const Bytes all = every_byte();
    const auto got = receive(line(9600, "8E1"), line(9600, "8N1"), all);
    ASSERT_EQ(got.size(), 256u);
    for (std::size_t i = 0; i < 256; ++i) {
        Received want = clean(all[i]);
        want.framing_error = even_ones(all[i]);
        want.line_break = all[i] == 0;
        EXPECT_EQ(untimed({got[i]}), untimed({want})) << i;
    }
}

TEST(UartModel, ParityReceiverOnANoParityWireLosesStep) {
    // 0x01 0x01 at 8N1: bits 0-9 = 0 1 0000000 1, bits 10-19 the same, then idle.
    // The 8E1 receiver reads D0-D7 = 0x01, its parity bit at bit 9 (1: 0x01 has one 1,
    // so the parity is right) and its stop bit at bit 10, the second start bit: 0, a
    // framing error. It then waits for a fall after that sample: bit 11 is 1, bit 12 is 0,
    // so it starts on bit 12 and reads bits 13-20 as data: six 0s, the stop bit and the
    // idle line (1, 1): 0xC0. Its parity bit (bit 21, idle) is 1: 0xC0 has two 1s, even
    // parity wants 0: a parity error. Its stop bit (bit 22) is the idle line: no framing
    // error.
    const auto got = receive(line(9600, "8N1"), line(9600, "8E1"), {0x01, 0x01});
    Received first = clean(0x01);
    first.framing_error = true;
    Received second = clean(0xC0);
    second.parity_error = true;
    EXPECT_EQ(untimed(got), (std::vector<Received>{first, second}));
    // The first stop sample is 10.5 bit times after the start: 10.5e9 / 9600 ns.
    ASSERT_FALSE(got.empty());
    EXPECT_EQ(got[0].time, kStart + 1'093'750);

    // A long back-to-back stream: errors, and bytes that are not those sent.
    const Bytes all = every_byte();
    const auto stream = receive(line(9600, "8N1"), line(9600, "8E1"), all);
    std::size_t errors = 0;
    std::size_t same = 0;
    for (std::size_t i = 0; i < stream.size(); ++i) {
        errors += stream[i].framing_error || stream[i].parity_error ? 1 : 0;
        same += stream[i].byte == all[i] ? 1 : 0;
    }
    EXPECT_GT(errors, stream.size() / 2);
    EXPECT_LT(same, stream.size() / 2);
}

TEST(UartModel, OddParityReceiverOnEvenParityWireFlagsEveryByte) {
    // Same positions for data, parity and stop bits; only the parity sense differs.
    const Bytes all = every_byte();
    const auto got = receive(line(9600, "8E1"), line(9600, "8O1"), all);
    ASSERT_EQ(got.size(), 256u);
    for (std::size_t i = 0; i < 256; ++i) {
        Received want = clean(all[i]);
        want.parity_error = true;
        EXPECT_EQ(untimed({got[i]}), untimed({want})) << i;
    }
}

TEST(UartModel, SevenBitReceiverTakesD7ForTheParityBit) {
    // 7E1 on an 8N1 wire: D0-D6 are its data (top bit 0), D7 (bit 8) its parity bit, bit
    // 9 (the stop bit) its stop bit. Parity error when D0-D6 and D7 together have an odd
    // number of ones, i.e. when the byte has; never a framing error; in step.
    const Bytes all = every_byte();
    const auto got = receive(line(9600, "8N1"), line(9600, "7E1"), all);
    ASSERT_EQ(got.size(), 256u);
    for (std::size_t i = 0; i < 256; ++i) {
        Received want = clean(all[i] & 0x7F);
        want.parity_error = !even_ones(all[i]);
        EXPECT_EQ(untimed({got[i]}), untimed({want})) << i;
    }
}

TEST(UartModel, TwiceTheBaudRateReadsTheFirstHalfOfEachCharacter) {
    // At 19200 a receiver bit is half a 9600 bit: its sample j falls at wire bit
    // (j + 0.5) / 2. 0xFF: start 0.25 -> bit 0 (start, 0); data at 0.75 (bit 0: 0),
    // 1.25 ... 4.25 (bits 1-4: 1): 0xFE; stop at 4.75 (bit 4: 1). No fall until the next
    // start bit. 0x00: bits 0-8 are 0, so every sample up to the stop bit (4.75) is 0: a
    // break. Then the line rises (bit 9) and stays idle: nothing more.
    const auto got = receive(line(9600, "8N1"), line(19200, "8N1"), {0xFF, 0x00});
    Received brk = clean(0x00);
    brk.framing_error = true;
    brk.line_break = true;
    EXPECT_EQ(untimed(got), (std::vector<Received>{clean(0xFE), brk}));
    ASSERT_FALSE(got.empty());
    EXPECT_EQ(got[0].time, kStart + 494'792);  // 9.5e9 / 19200 ns, rounded up

    // Each receiver character spans under 5 wire bits from its fall to its stop sample,
    // so at most two fit in a 10-bit wire character; one starts at least every other
    // wire character, since every wire character begins with a fall.
    Bytes stream(100);
    for (std::size_t i = 0; i < stream.size(); ++i) stream[i] = static_cast<std::uint8_t>(i * 37);
    const auto many = receive(line(9600, "8N1"), line(19200, "8N1"), stream);
    EXPECT_GE(many.size(), stream.size() / 2 - 1);
    EXPECT_LE(many.size(), 2 * stream.size() + 1);
    EXPECT_NE(untimed(many), untimed(receive(line(9600, "8N1"), line(9600, "8N1"), stream)));
}

TEST(UartModel, HalfTheBaudRateReadsOneCharacterOfTwo) {
    // At 4800 a receiver bit is two 9600 bits: its sample j falls at wire bit 2j + 1, on a
    // bit boundary, so the bytes are chosen with equal bits either side of every sampled
    // boundary. 0x80 0x80: bits 0-7 are 0, bits 8-9 (D7, stop) 1, again from 10. Start at
    // 1 (0), data at 3, 5, 7, 9, 11, 13, 15, 17 = 0 0 0 1 0 0 0 0 = 0x08, stop at 19 (1).
    // The next fall is the third character's start bit: one character per two.
    const Bytes pairs(10, 0x80);
    const auto got = receive(line(9600, "8N1"), line(4800, "8N1"), pairs);
    EXPECT_EQ(untimed(got), std::vector<Received>(5, clean(0x08)));

    // A receiver character spans 19 wire bits from its fall to its stop sample: at most
    // one per 1.9 wire characters.
    Bytes stream(100);
    for (std::size_t i = 0; i < stream.size(); ++i) stream[i] = static_cast<std::uint8_t>(i * 37);
    const auto many = receive(line(9600, "8N1"), line(4800, "8N1"), stream);
    EXPECT_LE(many.size(), stream.size() * 10 / 19 + 1);
    EXPECT_GE(many.size(), 1u);
}

TEST(UartModel, FastWireAtASlowReceiverGivesAFewGarbledCharacters) {
    // A 9600 receiver bit is 12 bits at 115200: one receiver character spans 114 wire bits
    // from its fall to its stop sample, so 120 wire characters (1200 bits) give at most 11.
    // A stream of zeros holds a start bit for it at the first fall.
    const Bytes zeros(120, 0x00);
    const auto got = receive(line(115200, "8N1"), line(9600, "8N1"), zeros);
    EXPECT_GE(got.size(), 1u);
    EXPECT_LE(got.size(), 11u);
    // 0xFF at 115200 is a start bit shorter than half a receiver bit: only glitches.
    EXPECT_TRUE(receive(line(115200, "8N1"), line(9600, "8N1"), Bytes(120, 0xFF)).empty());
}

TEST(UartModel, AfterABreakTheReceiverWaitsForTheLineToRise) {
    // 0x00 at 8E1 has parity bit 0: bits 0-9 are 0, the 8N1 receiver's stop sample (bit
    // 9) too: a break. Bit 10 (the stop bit) is 1, and the next character (0x01: one 1,
    // parity 1, so its bit 9 is 1) starts at bit 11 and reads clean. A receiver that took
    // the low stop bit for the next start bit would read garbage instead.
    const auto got = receive(line(9600, "8E1"), line(9600, "8N1"), {0x00, 0x01});
    Received brk = clean(0x00);
    brk.framing_error = true;
    brk.line_break = true;
    EXPECT_EQ(untimed(got), (std::vector<Received>{brk, clean(0x01)}));
}

TEST(UartModel, StreamingGivesWhatOneCallGives) {
    // Characters sent as the bus sends them (each before its start) and collected at
    // every start: the same as all at once, each reported no earlier than it completes.
    const LineSettings wire = line(9600, "8N1");
    const LineSettings receiver = line(19200, "8E1");
    Bytes stream(60);
    for (std::size_t i = 0; i < stream.size(); ++i) stream[i] = static_cast<std::uint8_t>(i * 53);
    UartResampler uart(wire, receiver);
    std::vector<Received> got;
    Nanos t = kStart;
    for (const std::uint8_t b : stream) {
        const std::size_t before = got.size();
        uart.take_until(t, got);
        for (std::size_t k = before; k < got.size(); ++k) EXPECT_LE(got[k].time, t);
        uart.send(t, b);
        t += wire.char_time() + (b % 3 == 0 ? 300'000 : 0);  // some gaps
    }
    // With everything sent, the next completion is exact: nothing comes a nanosecond
    // before it, a character at it.
    while (const auto next = uart.next_completion()) {
        const std::size_t before = got.size();
        uart.take_until(*next - 1, got);
        EXPECT_EQ(got.size(), before);
        uart.take_until(*next, got);
        ASSERT_GT(got.size(), before);
        EXPECT_EQ(got[before].time, *next);
    }
    UartResampler batch(wire, receiver);
    t = kStart;
    for (const std::uint8_t b : stream) {
        batch.send(t, b);
        t += wire.char_time() + (b % 3 == 0 ? 300'000 : 0);
    }
    std::vector<Received> all;
    batch.take_until(t + kNanosPerSecond, all);
    EXPECT_EQ(got, all);
    EXPECT_FALSE(all.empty());
}

TEST(UartModel, AReceiverJoiningMidStreamStartsAtTheNextFall) {
    // Listening from the exact start of the third character: the first two are not heard.
    const LineSettings l = line(9600, "8N1");
    UartResampler uart(l, l, kStart + 2 * l.char_time());
    const Bytes bytes = {0x11, 0x22, 0x33, 0x44};
    for (std::size_t i = 0; i < bytes.size(); ++i) {
        uart.send(kStart + static_cast<Nanos>(i) * l.char_time(), bytes[i]);
    }
    std::vector<Received> got;
    uart.take_until(kStart + kNanosPerSecond, got);
    EXPECT_EQ(untimed(got), (std::vector<Received>{clean(0x33), clean(0x44)}));
}

}  // namespace
}  // namespace rtuscope::sim
