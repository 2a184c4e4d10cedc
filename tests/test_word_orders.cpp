// Values of several registers in each word order: the bytes of a known number laid on
// the wire as docs/profiles.md draws them, decoded back to the number's text, and the
// value.partial note for a 64-bit value cut by its block.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <array>
#include <bit>
#include <cstdint>
#include <string>
#include <vector>

#include "profiles/values.hpp"

namespace rtuscope {
namespace {

// Where each byte of the value goes on the wire, A its most significant byte: the table
// of docs/profiles.md.
struct Layout {
    const char* order;  // as a profile names it
    const char* bytes_32;
    const char* bytes_64;
};

constexpr std::array<Layout, 6> kLayouts = {{
    {"abcd", "ABCD", "ABCDEFGH"},
    {"cdab", "CDAB", "GHEFCDAB"},
    {"badc", "BADC", "BADCFEHG"},
    {"dcba", "DCBA", "HGFEDCBA"},
    {"high_first", "ABCD", "ABCDEFGH"},
    {"low_first", "CDAB", "GHEFCDAB"},
}};

// The registers that carry `value` (of `size` bytes) in the layout `bytes`.
std::vector<std::uint16_t> wire_words(std::uint64_t value, std::size_t size, const char* bytes) {
    std::vector<std::uint8_t> wire;
    for (std::size_t i = 0; i < size; ++i) {
        const auto significance = static_cast<std::size_t>(bytes[i] - 'A');  // 0: the top byte
        wire.push_back(static_cast<std::uint8_t>(value >> (8 * (size - 1 - significance))));
    }
    std::vector<std::uint16_t> words;
    for (std::size_t i = 0; i < wire.size(); i += 2) {
        words.push_back(static_cast<std::uint16_t>((wire[i] << 8U) | wire[i + 1]));
    }
    return words;
}

struct Known {
    const char* type;
    std::uint64_t bits;  // the value's bytes
    std::string text;    // how a value of the type prints
};

// Each value has eight different bytes, so that any byte out of place changes it.
std::vector<Known> known_values() {
    const std::int32_t i32 = -123456789;
    const float f32 = -1234.5678F;
    const std::int64_t i64 = -1234567890123456789;
    const double f64 = -12345.678901234567;
    return {
        {"u32", 0xDEADBEEFU, "3735928559"},
        {"i32", static_cast<std::uint32_t>(i32), std::to_string(i32)},
        {"f32", std::bit_cast<std::uint32_t>(f32), fmt::format("{}", f32)},
        {"u64", 0xFEDCBA9876543210U, "18364758544493064720"},
        {"i64", static_cast<std::uint64_t>(i64), std::to_string(i64)},
        {"f64", std::bit_cast<std::uint64_t>(f64), fmt::format("{}", f64)},
    };
}

Profile one_register(ValueType type, WordOrder order) {
    Profile p;
    p.name = "orders";
    Register r;
    r.address = 0x0020;
    r.name = "value";
    r.type = type;
    r.word_order = order;
    r.length = registers_of(type);
    p.registers.push_back(r);
    return p;
}

std::vector<DecodedValue> decode(const Profile& profile, std::uint16_t start,
                                 std::vector<std::uint16_t> words) {
    DataBlock block;
    block.table = DataTable::holding_registers;
    block.start = start;
    block.values = std::move(words);
    ReusedList<DecodedValue> out;
    decode_values(profile, block, out);
    return {out.begin(), out.end()};
}

TEST(WordOrders, EveryTypeInEveryOrderDecodesItsValue) {
    for (const Known& known : known_values()) {
        const ValueType type = *value_type_named(known.type);
        const std::size_t size = registers_of(type) * 2U;
        for (const Layout& layout : kLayouts) {
            SCOPED_TRACE(fmt::format("{} {}", known.type, layout.order));
            const auto order = word_order_named(layout.order);
            ASSERT_TRUE(order.has_value());
            const auto words =
                wire_words(known.bits, size, size == 4 ? layout.bytes_32 : layout.bytes_64);
            const auto values = decode(one_register(type, *order), 0x0020, words);
            ASSERT_EQ(values.size(), 1U);
            EXPECT_EQ(values[0].name, "value");
            EXPECT_EQ(values[0].value, known.text);
            EXPECT_TRUE(values[0].notes.empty());
        }
    }
}

// The example of the Modbus tools' tables: 15.0 is 0x41700000.
TEST(WordOrders, FifteenAsF32InEachOrder) {
    const std::vector<std::pair<const char*, std::vector<std::uint16_t>>> wires = {
        {"abcd", {0x4170, 0x0000}},
        {"cdab", {0x0000, 0x4170}},
        {"badc", {0x7041, 0x0000}},
        {"dcba", {0x0000, 0x7041}},
    };
    for (const auto& [name, words] : wires) {
        SCOPED_TRACE(name);
        const auto values = decode(one_register(ValueType::f32, *word_order_named(name)), 0x0020,
                                   words);
        ASSERT_EQ(values.size(), 1U);
        EXPECT_EQ(values[0].value, "15");
    }
}

TEST(WordOrders, SixtyFourBitValuesTakeScaleAndUnit) {
    Profile p = one_register(ValueType::i64, WordOrder::abcd);
    p.registers[0].decimals = 3;
    p.registers[0].scale = scale_for_decimals(3);
    p.registers[0].unit = "kWh";
    const std::int64_t raw = -9876543210;
    const auto values = decode(p, 0x0020, wire_words(static_cast<std::uint64_t>(raw), 8, "ABCDEFGH"));
    ASSERT_EQ(values.size(), 1U);
    EXPECT_EQ(values[0].value, "-9876543.210");
    EXPECT_EQ(values[0].unit, "kWh");
    EXPECT_EQ(values[0].raw, "0xFFFF 0xFFFD 0xB34F 0xE916");
}

TEST(WordOrders, SixtyFourBitValueReadInPartIsPartial) {
    const Profile p = one_register(ValueType::f64, WordOrder::cdab);
    const auto words = wire_words(std::bit_cast<std::uint64_t>(1.5), 8, "GHEFCDAB");

    const auto head = decode(p, 0x001F, {0x0001, words[0], words[1]});
    ASSERT_EQ(head.size(), 2U);
    EXPECT_EQ(head[1].address, 0x0020);
    EXPECT_EQ(head[1].value, "");
    ASSERT_EQ(head[1].notes.size(), 1U);
    EXPECT_STREQ(head[1].notes[0].id, note_id::value_partial);
    EXPECT_EQ(head[1].notes[0].text,
              "only the first 2 of 4 registers of a 64-bit value (0x0020-0x0023)");

    const auto tail = decode(p, 0x0023, {words[3]});
    ASSERT_EQ(tail.size(), 1U);
    ASSERT_EQ(tail[0].notes.size(), 1U);
    EXPECT_STREQ(tail[0].notes[0].id, note_id::value_partial);
    EXPECT_EQ(tail[0].notes[0].text,
              "only the last 1 of 4 registers of a 64-bit value (0x0020-0x0023)");

    const auto middle = decode(p, 0x0021, {words[1], words[2]});
    ASSERT_EQ(middle.size(), 1U);
    ASSERT_EQ(middle[0].notes.size(), 1U);
    EXPECT_EQ(middle[0].notes[0].text,
              "only registers 2-3 of 4 of a 64-bit value (0x0020-0x0023)");
}

// In the orders that put the least significant register first, the one register of a
// 32-bit value read alone at its address is its low word.
TEST(WordOrders, HalfOfA32BitValueNamesItsWord) {
    const std::vector<std::pair<const char*, const char*>> first_words = {
        {"abcd", "high"}, {"badc", "high"}, {"cdab", "low"}, {"dcba", "low"}};
    for (const auto& [name, word] : first_words) {
        SCOPED_TRACE(name);
        const auto values =
            decode(one_register(ValueType::u32, *word_order_named(name)), 0x0020, {0x1234});
        ASSERT_EQ(values.size(), 1U);
        ASSERT_EQ(values[0].notes.size(), 1U);
        EXPECT_EQ(values[0].notes[0].text,
                  fmt::format("only the {} word of a 32-bit value (0x0020-0x0021)", word));
    }
}

TEST(WordOrders, NamesReadBackAsTheSameOrder) {
    for (const Layout& layout : kLayouts) {
        const auto order = word_order_named(layout.order);
        ASSERT_TRUE(order.has_value());
        EXPECT_EQ(word_order_named(word_order_name(*order)), order);
    }
    EXPECT_EQ(word_order_named("ABCD"), std::nullopt);
    EXPECT_EQ(word_order_named("bcda"), std::nullopt);
}

}  // namespace
}  // namespace rtuscope
