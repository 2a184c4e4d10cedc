// --as: registers typed on the command line, what each part of the text gives, the
// mistakes it reports, and how the typed registers join a slave's profile.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <tuple>
#include <vector>

#include "profiles/quick_type.hpp"
#include "profiles/values.hpp"

namespace rtuscope {
namespace {

QuickType parsed(const std::string& text) {
    auto q = parse_quick_type(text);
    EXPECT_TRUE(q) << (q ? "" : q.error().message);
    return q ? *q : QuickType{};
}

std::string mistake(const std::string& text) {
    auto q = parse_quick_type(text);
    EXPECT_FALSE(q) << text;
    return q ? "" : q.error().message;
}

TEST(QuickType, ReadsSlaveTableAddressTypeAndOrder) {
    const QuickType q = parsed("247:input:0x4082=f32/cdab");
    EXPECT_EQ(q.slave, 247);
    EXPECT_EQ(q.reg.table, "input");
    EXPECT_EQ(q.reg.address, 0x4082);
    EXPECT_EQ(q.reg.name, "reg_0x4082");
    EXPECT_EQ(q.reg.type, ValueType::f32);
    EXPECT_EQ(q.reg.word_order, WordOrder::cdab);
    EXPECT_EQ(q.reg.length, 2);
    EXPECT_EQ(q.reg.scale, 1.0);
    EXPECT_EQ(q.reg.unit, "");
}

TEST(QuickType, ReadsScaleAndUnitWithTheHoldingTableByDefault) {
    const QuickType q = parsed("3:0x0010=u16*0.1:V");
    EXPECT_EQ(q.slave, 3);
    EXPECT_EQ(q.reg.table, "holding");
    EXPECT_EQ(q.reg.address, 0x0010);
    EXPECT_EQ(q.reg.type, ValueType::u16);
    EXPECT_DOUBLE_EQ(q.reg.scale, 0.1);
    EXPECT_EQ(q.reg.unit, "V");

    const QuickType wide = parsed("0x10:holding:16=f64/dcba*2.5:m³/h");
    EXPECT_EQ(wide.slave, 16);
    EXPECT_EQ(wide.reg.address, 16);
    EXPECT_EQ(wide.reg.length, 4);
    EXPECT_EQ(wide.reg.word_order, WordOrder::dcba);
    EXPECT_DOUBLE_EQ(wide.reg.scale, 2.5);
    EXPECT_EQ(wide.reg.unit, "m³/h");
    EXPECT_EQ(parsed("1:coil:5=u16").reg.table, "coil");
    EXPECT_EQ(parsed("1:7=u32/low_first").reg.word_order, WordOrder::cdab);
}

TEST(QuickType, MistakesSayWhatIsWrong) {
    const std::string expected =
        " (expected SLAVE[:TABLE]:ADDR=TYPE[/ORDER][*SCALE][:UNIT], e.g. "
        "247:input:0x4082=f32/cdab or 3:0x0010=u16*0.1:V)";
    EXPECT_EQ(mistake("3:0x10"), "bad --as \"3:0x10\": no =TYPE" + expected);
    EXPECT_EQ(mistake("3=u16"), "bad --as \"3=u16\": no :ADDR after the slave" + expected);
    EXPECT_EQ(mistake("300:1=u16"),
              "bad --as \"300:1=u16\": slave \"300\" is not an address 0-255" + expected);
    EXPECT_EQ(mistake("3:eeprom:1=u16"),
              "bad --as \"3:eeprom:1=u16\": unknown table \"eeprom\" (holding, input, coil, "
              "discrete)" + expected);
    EXPECT_EQ(mistake("3:0x1FFFF=u16"),
              "bad --as \"3:0x1FFFF=u16\": address \"0x1FFFF\" is not a number 0-65535 "
              "(decimal or 0x hex)" + expected);
    EXPECT_EQ(mistake("3:1=u24"),
              "bad --as \"3:1=u24\": unknown type \"u24\" (u16, i16, u32, i32, f32, u64, i64, "
              "f64, bits, enum, string)" + expected);
    EXPECT_EQ(mistake("3:1=f32/bacd"),
              "bad --as \"3:1=f32/bacd\": unknown word order \"bacd\" (abcd, cdab, badc, dcba, "
              "high_first (abcd), low_first (cdab))" + expected);
    EXPECT_EQ(mistake("3:1=u16/cdab"),
              "bad --as \"3:1=u16/cdab\": /cdab: a word order is only for u32, i32, f32, u64, "
              "i64 and f64" + expected);
    EXPECT_EQ(mistake("3:1=u16*0"),
              "bad --as \"3:1=u16*0\": scale \"0\" is not a number other than 0" + expected);
    EXPECT_EQ(mistake("3:1=u16*x:V"),
              "bad --as \"3:1=u16*x:V\": scale \"x\" is not a number other than 0" + expected);
    EXPECT_EQ(mistake("3:1=u16:"), "bad --as \"3:1=u16:\": an empty :UNIT" + expected);
    EXPECT_EQ(mistake("3:1=enum"),
              "bad --as \"3:1=enum\": type enum needs a profile (its labels)" + expected);
    EXPECT_EQ(mistake("3:coil:1=f32"),
              "bad --as \"3:coil:1=f32\": a coil is a single bit: type u16" + expected);
    EXPECT_EQ(mistake("3:0xFFFE=u64"),
              "bad --as \"3:0xFFFE=u64\": a u64 at 0xFFFE goes past address 0xFFFF" + expected);
}

std::vector<DecodedValue> decode(const Profile& profile, DataTable table, std::uint16_t start,
                                 std::vector<std::uint16_t> words) {
    DataBlock block;
    block.table = table;
    block.start = start;
    block.values = std::move(words);
    ReusedList<DecodedValue> out;
    decode_values(profile, block, out);
    return {out.begin(), out.end()};
}

TEST(QuickType, GivesASlaveWithoutAProfileOneOfItsRegisters) {
    Bus bus;
    apply_quick_types(bus, {parsed("247:input:0x4082=f32/cdab"), parsed("247:0x10=i16*0.1:V")});
    const Profile* p = bus.profile_for(247);
    ASSERT_NE(p, nullptr);
    EXPECT_EQ(p->name, "as-247");
    EXPECT_EQ(bus.profile_for(246), nullptr);
    EXPECT_EQ(bus.find_profile("as-247"), nullptr);  // not a profile --device could name

    // 15.0 as an f32, low word first.
    const auto values = decode(*p, DataTable::input_registers, 0x4082, {0x0000, 0x4170});
    ASSERT_EQ(values.size(), 1U);
    EXPECT_EQ(values[0].name, "reg_0x4082");
    EXPECT_EQ(values[0].value, "15");
    EXPECT_TRUE(values[0].notes.empty());

    const auto volts = decode(*p, DataTable::holding_registers, 0x10, {0xFF38, 7});
    ASSERT_EQ(volts.size(), 2U);
    EXPECT_EQ(volts[0].value, "-20.0");
    EXPECT_EQ(volts[0].unit, "V");
    EXPECT_EQ(volts[1].name, "");  // 0x0011: not typed
}

// pdu485 (bundled): 0x0004 is its 32-bit energy counter, 0x0000 its voltage.
TEST(QuickType, AddsToOrOverridesTheSlavesProfileAndNoOtherSlaves) {
    Bus bus;
    ASSERT_TRUE(bus.assign(1, "pdu485"));
    ASSERT_TRUE(bus.assign(2, "pdu485"));
    const Profile* original = bus.profile_for(2);
    ASSERT_NE(original, nullptr);
    ASSERT_NE(original->register_at("holding", 4), nullptr);
    ASSERT_EQ(original->register_at("holding", 0x3000), nullptr);
    const std::string energy = original->register_at("holding", 4)->name;

    apply_quick_types(bus, {parsed("1:4=u32/abcd*0.001:MWh"), parsed("1:0x3000=u64")});
    const Profile* typed = bus.profile_for(1);
    ASSERT_NE(typed, nullptr);
    EXPECT_EQ(typed->name, "pdu485");
    EXPECT_EQ(bus.profile_for(2), original);
    EXPECT_EQ(bus.find_profile("pdu485"), original);

    const Register* overridden = typed->register_at("holding", 4);
    ASSERT_NE(overridden, nullptr);
    EXPECT_EQ(overridden->name, energy);
    EXPECT_EQ(overridden->word_order, WordOrder::abcd);
    EXPECT_EQ(overridden->unit, "MWh");
    const auto values = decode(*typed, DataTable::holding_registers, 4, {0x0001, 0x0000});
    ASSERT_EQ(values.size(), 1U);
    EXPECT_EQ(values[0].value, "65.536");

    const Register* added = typed->register_at("holding", 0x3000);
    ASSERT_NE(added, nullptr);
    EXPECT_EQ(added->name, "reg_0x3000");
    EXPECT_EQ(added->length, 4);
    // The rest of the profile is as it was, and in order.
    EXPECT_EQ(typed->registers.size(), original->registers.size() + 1);
    EXPECT_TRUE(std::is_sorted(typed->registers.begin(), typed->registers.end(),
                               [](const Register& a, const Register& b) {
                                   return std::tie(a.table, a.address) <
                                          std::tie(b.table, b.address);
                               }));
}

// A typed register that covers part of one the profile lists replaces it.
TEST(QuickType, ReplacesTheRegistersItOverlaps) {
    Bus bus;
    ASSERT_TRUE(bus.assign(1, "pdu485"));
    apply_quick_types(bus, {parsed("1:5=u16")});
    const Profile* typed = bus.profile_for(1);
    EXPECT_EQ(typed->register_at("holding", 4), nullptr);
    ASSERT_NE(typed->register_at("holding", 5), nullptr);
    EXPECT_EQ(typed->register_at("holding", 5)->name, "reg_0x0005");
}

}  // namespace
}  // namespace rtuscope
