// Register values explained with a profile: types, scales, word orders, labels, and the
// value.* notes for blocks that cut registers, registers the profile does not list,
// out-of-range values and writes.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "profiles/values.hpp"

namespace rtuscope {
namespace {

Register reg(std::string table, std::uint16_t address, std::string name, ValueType type,
             std::uint16_t length = 1) {
    Register r;
    r.table = std::move(table);
    r.address = address;
    r.name = std::move(name);
    r.type = type;
    r.length = length;
    return r;
}

Register with_decimals(Register r, int decimals, std::string unit) {
    r.decimals = decimals;
    r.scale = 1.0;
    for (int i = 0; i < decimals; ++i) r.scale /= 10;
    r.unit = std::move(unit);
    return r;
}

// A small meter, sorted by table then address as the loader leaves it.
Profile meter() {
    Profile p;
    p.name = "meter";

    Register coil_relay = reg("coil", 0x0000, "relay", ValueType::enumeration);
    coil_relay.labels = {{0, "open"}, {1, "closed"}};
    coil_relay.access = Access::read_write;
    p.registers.push_back(coil_relay);
    p.registers.push_back(reg("coil", 0x0001, "fan", ValueType::u16));

    Register coefficient = with_decimals(reg("eeprom", 0x0010, "k_voltage", ValueType::u16), 3, "");
    coefficient.access = Access::read_write;
    p.registers.push_back(coefficient);

    Register voltage = with_decimals(reg("holding", 0x0000, "voltage", ValueType::u16), 1, "V");
    voltage.min = 0.0;
    voltage.max = 300.0;
    p.registers.push_back(voltage);
    p.registers.push_back(
        with_decimals(reg("holding", 0x0001, "temperature", ValueType::i16), 1, "°C"));
    Register energy = reg("holding", 0x0002, "energy", ValueType::u32, 2);
    energy.unit = "Wh";
    energy.access = Access::read_write;
    energy.writes = {{0x0000AABB, "clear the energy counter"}};
    p.registers.push_back(energy);
    Register count = reg("holding", 0x0004, "count", ValueType::u32, 2);
    count.word_order = WordOrder::cdab;
    p.registers.push_back(count);
    p.registers.push_back(reg("holding", 0x0006, "offset", ValueType::i32, 2));
    Register power = reg("holding", 0x0008, "power", ValueType::f32, 2);
    power.unit = "W";
    p.registers.push_back(power);
    Register baud = reg("holding", 0x000A, "baud", ValueType::enumeration);
    baud.labels = {{0, "1200 baud"}, {1, "2400 baud"}, {3, "9600 baud"}};
    baud.access = Access::read_write;
    p.registers.push_back(baud);
    Register status = reg("holding", 0x000B, "status", ValueType::bits);
    status.labels = {{0, "relay 1"}, {15, "alarm"}};
    p.registers.push_back(status);
    p.registers.push_back(reg("holding", 0x000C, "model", ValueType::string, 3));
    // 0x000F-0x000F is a hole: not in the profile.
    Register reading = reg("holding", 0x0010, "reading", ValueType::u16);
    reading.scale = 0.1;  // a scale without decimals: the digits come from the scale
    reading.min = -1.0;
    p.registers.push_back(reading);
    Register half = reg("holding", 0x0011, "half", ValueType::i16);
    half.scale = 0.5;
    p.registers.push_back(half);
    Register high = reg("holding", 0xFFFE, "last", ValueType::u16);
    high.max = 100.0;
    p.registers.push_back(high);

    p.registers.push_back(reg("input", 0x0000, "uv", ValueType::u16));
    return p;
}

// Every value of the block, as a list of its own.
std::vector<DecodedValue> decode_values(const Profile& profile, const DataBlock& block) {
    ReusedList<DecodedValue> decoded;
    rtuscope::decode_values(profile, block, decoded);
    return {decoded.begin(), decoded.end()};
}

DataBlock holding(std::uint16_t start, std::vector<std::uint16_t> values, bool write = false) {
    DataBlock b;
    b.table = DataTable::holding_registers;
    b.start = start;
    b.values = std::move(values);
    b.write = write;
    return b;
}

// The one value a block decodes to; fails the test when there is not exactly one.
DecodedValue only(const std::vector<DecodedValue>& values) {
    EXPECT_EQ(values.size(), 1U);
    return values.empty() ? DecodedValue{} : values.front();
}

std::vector<std::string> note_ids(const DecodedValue& v) {
    std::vector<std::string> ids;
    for (const Note& n : v.notes) ids.emplace_back(n.id);
    return ids;
}

// `decimals = N` on an integer register is printed from the integer's digits, not by
// formatting raw * 10^-N as a double: the text must be what fmt prints for that double.
TEST(Values, DecimalsPrintAsTheScaledDoubleWould) {
    std::vector<std::int64_t> raws = {
        0,     1,     -1,     5,     -5,     9,     10,         -10,         99,         100,
        12345, 32767, -32768, 65535, 999999, -1000, 2147483647, -2147483647, -2147483648};
    std::uint32_t x = 12345;  // a fixed xorshift sequence: the same values every run
    for (int i = 0; i < 2000; ++i) {
        x ^= x << 13U;
        x ^= x >> 17U;
        x ^= x << 5U;
        raws.push_back(static_cast<std::int32_t>(x));
    }
    for (int decimals = 0; decimals <= 9; ++decimals) {
        Profile p;
        Register r = reg("holding", 0x0000, "value", ValueType::i32, 2);
        r.decimals = decimals;
        r.scale = std::pow(10.0, -static_cast<double>(decimals));  // as the loader does
        p.registers.push_back(r);
        for (const std::int64_t raw : raws) {
            const auto word = static_cast<std::uint32_t>(raw);
            const DecodedValue v = only(
                decode_values(p, holding(0x0000, {static_cast<std::uint16_t>(word >> 16U),
                                                  static_cast<std::uint16_t>(word & 0xFFFFU)})));
            const double scaled = static_cast<double>(raw) * r.scale;
            ASSERT_EQ(v.value, fmt::format("{:.{}f}", scaled, decimals))
                << raw << " with " << decimals << " decimals";
        }
    }
}

TEST(Values, TableNames) {
    EXPECT_STREQ(table_name(DataTable::coils), "coil");
    EXPECT_STREQ(table_name(DataTable::discrete_inputs), "discrete");
    EXPECT_STREQ(table_name(DataTable::holding_registers), "holding");
    EXPECT_STREQ(table_name(DataTable::input_registers), "input");
}

TEST(Values, U16WithDecimals) {
    const DecodedValue v = only(decode_values(meter(), holding(0x0000, {0x1818})));
    EXPECT_EQ(v.address, 0x0000);
    EXPECT_EQ(v.name, "voltage");
    EXPECT_EQ(v.value, "616.8");
    EXPECT_EQ(v.unit, "V");
    EXPECT_EQ(v.raw, "0x1818");
    // 616.8 V is beyond the profile's 300 V: the value is still shown, and flagged.
    EXPECT_EQ(note_ids(v), std::vector<std::string>{note_id::value_out_of_range});
}

TEST(Values, I16NegativeWithDecimals) {
    const DecodedValue v = only(decode_values(meter(), holding(0x0001, {0xFFCE})));
    EXPECT_EQ(v.name, "temperature");
    EXPECT_EQ(v.value, "-5.0");
    EXPECT_EQ(v.unit, "°C");
    EXPECT_EQ(v.raw, "0xFFCE");
}

TEST(Values, NegativeZeroPrintsWithoutSign) {
    // -0.4 rounds to "-0" at no decimals: a sign on zero reads like a fault.
    Profile p;
    Register r = reg("holding", 0x0000, "tiny", ValueType::i16);
    r.scale = 0.1;
    r.decimals = 0;
    p.registers.push_back(r);
    EXPECT_EQ(only(decode_values(p, holding(0x0000, {0xFFFC}))).value, "0");
}

TEST(Values, U32HighFirst) {
    const DecodedValue v = only(decode_values(meter(), holding(0x0002, {0x0000, 0x3039})));
    EXPECT_EQ(v.address, 0x0002);
    EXPECT_EQ(v.name, "energy");
    EXPECT_EQ(v.value, "12345");
    EXPECT_EQ(v.unit, "Wh");
    EXPECT_EQ(v.raw, "0x0000 0x3039");
    EXPECT_TRUE(v.notes.empty());
}

TEST(Values, U32HighFirstUsesBothWords) {
    const DecodedValue v = only(decode_values(meter(), holding(0x0002, {0x0001, 0x0000})));
    EXPECT_EQ(v.value, "65536");
}

TEST(Values, U32LowFirst) {
    const DecodedValue v = only(decode_values(meter(), holding(0x0004, {0x3039, 0x0001})));
    EXPECT_EQ(v.name, "count");
    EXPECT_EQ(v.value, "77881");  // 0x00013039
    EXPECT_EQ(v.raw, "0x3039 0x0001");
}

TEST(Values, U32FullRangeIsUnsigned) {
    const DecodedValue v = only(decode_values(meter(), holding(0x0002, {0xFFFF, 0xFFFF})));
    EXPECT_EQ(v.value, "4294967295");
}

TEST(Values, I32Negative) {
    const DecodedValue v = only(decode_values(meter(), holding(0x0006, {0xFFFF, 0xFFFE})));
    EXPECT_EQ(v.name, "offset");
    EXPECT_EQ(v.value, "-2");
}

TEST(Values, F32) {
    const DecodedValue v = only(decode_values(meter(), holding(0x0008, {0x4348, 0x0000})));
    EXPECT_EQ(v.name, "power");
    EXPECT_EQ(v.value, "200");
    EXPECT_EQ(v.unit, "W");
    EXPECT_EQ(v.raw, "0x4348 0x0000");
}

TEST(Values, F32PrintsTheFloatNotItsDoubleExpansion) {
    // 0x3E99999A is the float nearest 0.3; as a double it would be 0.30000001192092896.
    EXPECT_EQ(only(decode_values(meter(), holding(0x0008, {0x3E99, 0x999A}))).value, "0.3");
    EXPECT_EQ(only(decode_values(meter(), holding(0x0008, {0xC2F7, 0x0000}))).value, "-123.5");
}

TEST(Values, ScaleWithoutDecimalsUsesTheScalesDigits) {
    const std::vector<DecodedValue> values =
        decode_values(meter(), holding(0x0010, {3, 0xFFFD}));  // reading 3 * 0.1, half -3 * 0.5
    ASSERT_EQ(values.size(), 2U);
    EXPECT_EQ(values[0].value, "0.3");
    EXPECT_EQ(values[1].value, "-1.5");
    EXPECT_EQ(only(decode_values(meter(), holding(0x0011, {4}))).value, "2.0");
}

TEST(Values, EnumHitAndMiss) {
    const DecodedValue hit = only(decode_values(meter(), holding(0x000A, {3})));
    EXPECT_EQ(hit.name, "baud");
    EXPECT_EQ(hit.value, "9600 baud");
    EXPECT_TRUE(hit.unit.empty());
    EXPECT_TRUE(hit.notes.empty());

    const DecodedValue miss = only(decode_values(meter(), holding(0x000A, {7})));
    EXPECT_EQ(miss.value, "7");
    EXPECT_EQ(miss.raw, "0x0007");
    ASSERT_EQ(miss.notes.size(), 1U);
    EXPECT_STREQ(miss.notes[0].id, note_id::value_out_of_range);
    EXPECT_EQ(miss.notes[0].text, "no label for 7");
}

TEST(Values, Bits) {
    EXPECT_EQ(only(decode_values(meter(), holding(0x000B, {0x8201}))).value,
              "relay 1, bit 9, alarm");
    EXPECT_EQ(only(decode_values(meter(), holding(0x000B, {0x0000}))).value, "none");
    EXPECT_EQ(only(decode_values(meter(), holding(0x000B, {0x8000}))).value, "alarm");
}

TEST(Values, StringStopsAtNulAndEscapesControlBytes) {
    const DecodedValue v = only(decode_values(meter(), holding(0x000C, {0x5A42, 0x2D31, 0x0041})));
    EXPECT_EQ(v.name, "model");
    EXPECT_EQ(v.value, "ZB-1");
    EXPECT_EQ(v.raw, "0x5A42 0x2D31 0x0041");
    EXPECT_TRUE(v.unit.empty());

    EXPECT_EQ(only(decode_values(meter(), holding(0x000C, {0x4101, 0x42FF, 0x4344}))).value,
              "A\\x01B\\xFFCD");
}

TEST(Values, BlockStartingInsideA32BitRegister) {
    const std::vector<DecodedValue> values =
        decode_values(meter(), holding(0x0003, {0x0001, 0x1818}));
    ASSERT_EQ(values.size(), 2U);
    EXPECT_EQ(values[0].address, 0x0003);
    EXPECT_EQ(values[0].name, "energy");
    EXPECT_EQ(values[0].value, "");
    EXPECT_EQ(values[0].unit, "");
    EXPECT_EQ(values[0].raw, "0x0001");
    ASSERT_EQ(values[0].notes.size(), 1U);
    EXPECT_STREQ(values[0].notes[0].id, note_id::value_partial);
    EXPECT_EQ(values[0].notes[0].text, "only the low word of a 32-bit value (0x0002-0x0003)");
    // The register after it is whole again: a partial value must not shift the rest.
    EXPECT_EQ(values[1].address, 0x0004);
    EXPECT_EQ(values[1].name, "count");
    EXPECT_EQ(values[1].raw, "0x1818");
    EXPECT_EQ(note_ids(values[1]), std::vector<std::string>{note_id::value_partial});
    EXPECT_EQ(values[1].notes[0].text, "only the low word of a 32-bit value (0x0004-0x0005)");
}

TEST(Values, BlockEndingInsideA32BitRegister) {
    const std::vector<DecodedValue> values =
        decode_values(meter(), holding(0x0001, {0x00FA, 0x0000}));
    ASSERT_EQ(values.size(), 2U);
    EXPECT_EQ(values[0].value, "25.0");
    EXPECT_EQ(values[1].address, 0x0002);
    EXPECT_EQ(values[1].name, "energy");
    EXPECT_EQ(values[1].value, "");
    EXPECT_EQ(values[1].raw, "0x0000");
    ASSERT_EQ(values[1].notes.size(), 1U);
    EXPECT_STREQ(values[1].notes[0].id, note_id::value_partial);
    EXPECT_EQ(values[1].notes[0].text, "only the high word of a 32-bit value (0x0002-0x0003)");
}

TEST(Values, BlockCuttingAString) {
    const std::vector<DecodedValue> values =
        decode_values(meter(), holding(0x000B, {0x0000, 0x5A42, 0x2D31}));
    ASSERT_EQ(values.size(), 2U);
    EXPECT_EQ(values[1].name, "model");
    EXPECT_EQ(values[1].raw, "0x5A42 0x2D31");
    EXPECT_EQ(values[1].value, "");
    ASSERT_EQ(values[1].notes.size(), 1U);
    EXPECT_EQ(values[1].notes[0].text, "only the first 2 of 3 registers (0x000C-0x000E)");

    const DecodedValue middle = only(decode_values(meter(), holding(0x000D, {0x2D31})));
    ASSERT_EQ(middle.notes.size(), 1U);
    EXPECT_EQ(middle.notes[0].text, "only registers 2-2 of 3 (0x000C-0x000E)");
}

TEST(Values, UnlistedRegistersComeOutOneEach) {
    const std::vector<DecodedValue> values =
        decode_values(meter(), holding(0x000E, {0x4344, 0x0000, 0x0005}));
    ASSERT_EQ(values.size(), 3U);
    EXPECT_EQ(values[0].name, "model");  // the last word of the string
    EXPECT_EQ(values[1].address, 0x000F);
    EXPECT_EQ(values[1].name, "");
    EXPECT_EQ(values[1].value, "0");
    EXPECT_EQ(values[1].raw, "0x0000");
    ASSERT_EQ(values[1].notes.size(), 1U);
    EXPECT_STREQ(values[1].notes[0].id, note_id::value_unlisted);
    EXPECT_EQ(values[1].notes[0].text, "not in the profile");
    EXPECT_EQ(values[2].name, "reading");
    EXPECT_EQ(values[2].value, "0.5");

    const std::vector<DecodedValue> far = decode_values(meter(), holding(0x0100, {1, 65535}));
    ASSERT_EQ(far.size(), 2U);
    EXPECT_EQ(far[0].address, 0x0100);
    EXPECT_EQ(far[1].address, 0x0101);
    EXPECT_EQ(far[1].value, "65535");
    EXPECT_EQ(far[1].raw, "0xFFFF");
    EXPECT_EQ(note_ids(far[1]), std::vector<std::string>{note_id::value_unlisted});
}

TEST(Values, OutOfRange) {
    const DecodedValue v = only(decode_values(meter(), holding(0x0000, {3001})));
    EXPECT_EQ(v.value, "300.1");
    ASSERT_EQ(v.notes.size(), 1U);
    EXPECT_STREQ(v.notes[0].id, note_id::value_out_of_range);
    EXPECT_EQ(v.notes[0].text, "outside 0.0..300.0 V");

    EXPECT_TRUE(only(decode_values(meter(), holding(0x0000, {3000}))).notes.empty());
}

TEST(Values, OutOfRangeWithOneBound) {
    const DecodedValue v = only(decode_values(meter(), holding(0xFFFE, {101})));
    EXPECT_EQ(v.name, "last");
    ASSERT_EQ(v.notes.size(), 1U);
    EXPECT_EQ(v.notes[0].text, "above 100");
    // reading has only a minimum (-1.0), which an unsigned value cannot go below.
    EXPECT_TRUE(only(decode_values(meter(), holding(0x0010, {0}))).notes.empty());
}

TEST(Values, WriteToReadOnly) {
    const DecodedValue v = only(decode_values(meter(), holding(0x0000, {0x0898}, true)));
    EXPECT_EQ(v.value, "220.0");
    ASSERT_EQ(v.notes.size(), 1U);
    EXPECT_STREQ(v.notes[0].id, note_id::value_read_only);
    EXPECT_EQ(v.notes[0].text, "written, but the profile says read-only");
    // The same register read back is no anomaly, and a writable one written is none.
    EXPECT_TRUE(only(decode_values(meter(), holding(0x0000, {0x0898}))).notes.empty());
    EXPECT_TRUE(only(decode_values(meter(), holding(0x000A, {1}, true))).notes.empty());
}

TEST(Values, SpecialWrite) {
    const DecodedValue v = only(decode_values(meter(), holding(0x0002, {0x0000, 0xAABB}, true)));
    EXPECT_EQ(v.name, "energy");
    EXPECT_EQ(v.value, "clear the energy counter");
    EXPECT_EQ(v.unit, "");
    EXPECT_EQ(v.raw, "0x0000 0xAABB");
    EXPECT_TRUE(v.notes.empty());
    // Read, the same raw value is just a number.
    EXPECT_EQ(only(decode_values(meter(), holding(0x0002, {0x0000, 0xAABB}))).value, "43707");
}

TEST(Values, ReadOfWriteOnlyRegister) {
    Profile p;
    Register all_on = reg("holding", 0x0002, "all_on", ValueType::u16);
    all_on.access = Access::write;
    p.registers.push_back(all_on);
    const DecodedValue read = only(decode_values(p, holding(0x0002, {0x017D})));
    EXPECT_EQ(read.value, "381");
    ASSERT_EQ(read.notes.size(), 1U);
    EXPECT_STREQ(read.notes[0].id, note_id::value_write_only);
    EXPECT_EQ(read.notes[0].text, "read, but the profile says write-only");
    EXPECT_TRUE(only(decode_values(p, holding(0x0002, {1}, true))).notes.empty());
}

TEST(Values, SpecialWriteIntoHalfOfA32BitRegister) {
    // The PDU manual: write 0xAABB (FC06, one register) to the energy register to clear it.
    const DecodedValue v = only(decode_values(meter(), holding(0x0002, {0xAABB}, true)));
    EXPECT_EQ(v.name, "energy");
    EXPECT_EQ(v.value, "clear the energy counter");
    EXPECT_EQ(v.raw, "0xAABB");
    EXPECT_TRUE(v.notes.empty());
    // Any other single word written there is half a value, and said so.
    const DecodedValue other = only(decode_values(meter(), holding(0x0003, {0x1234}, true)));
    EXPECT_EQ(other.value, "");
    ASSERT_EQ(other.notes.size(), 1U);
    EXPECT_STREQ(other.notes[0].id, note_id::value_partial);
}

TEST(Values, CoilTable) {
    DataBlock b;
    b.table = DataTable::coils;
    b.start = 0;
    b.values = {1, 0, 1};
    const std::vector<DecodedValue> values = decode_values(meter(), b);
    ASSERT_EQ(values.size(), 3U);
    EXPECT_EQ(values[0].name, "relay");
    EXPECT_EQ(values[0].value, "closed");
    EXPECT_EQ(values[0].raw, "1");
    EXPECT_EQ(values[1].name, "fan");
    EXPECT_EQ(values[1].value, "0");
    EXPECT_EQ(values[1].raw, "0");
    EXPECT_TRUE(values[1].notes.empty());
    EXPECT_EQ(values[2].name, "");
    EXPECT_EQ(values[2].value, "1");
    EXPECT_EQ(values[2].raw, "1");
    EXPECT_EQ(note_ids(values[2]), std::vector<std::string>{note_id::value_unlisted});

    b.values = {0, 1};
    b.write = true;
    const std::vector<DecodedValue> written = decode_values(meter(), b);
    ASSERT_EQ(written.size(), 2U);
    EXPECT_EQ(written[0].value, "open");
    EXPECT_TRUE(written[0].notes.empty());  // relay is read-write
    EXPECT_EQ(written[1].value, "1");
    EXPECT_EQ(note_ids(written[1]), std::vector<std::string>{note_id::value_read_only});
}

TEST(Values, DiscreteTableHasNoCoilNames) {
    DataBlock b;
    b.table = DataTable::discrete_inputs;
    b.values = {1};
    const DecodedValue v = only(decode_values(meter(), b));
    EXPECT_EQ(v.name, "");
    EXPECT_EQ(v.raw, "1");
}

TEST(Values, CustomTable) {
    DataBlock b;
    b.table = DataTable::holding_registers;  // replaced by the custom table
    b.custom_table = "eeprom";
    b.start = 0x0010;
    b.values = {1023};
    b.write = true;
    const DecodedValue v = only(decode_values(meter(), b));
    EXPECT_EQ(v.name, "k_voltage");
    EXPECT_EQ(v.value, "1.023");
    EXPECT_TRUE(v.notes.empty());

    b.start = 0x0000;  // holding 0x0000 is voltage, but eeprom 0x0000 is nothing
    const DecodedValue other = only(decode_values(meter(), b));
    EXPECT_EQ(other.name, "");
    EXPECT_EQ(note_ids(other), std::vector<std::string>{note_id::value_unlisted});
}

TEST(Values, InputTable) {
    DataBlock b;
    b.table = DataTable::input_registers;
    b.values = {42};
    const DecodedValue v = only(decode_values(meter(), b));
    EXPECT_EQ(v.name, "uv");
    EXPECT_EQ(v.value, "42");
}

TEST(Values, ShortAnswerDecodesOnlyWhatItCarries) {
    Profile p;
    p.registers.push_back(with_decimals(reg("holding", 0x0000, "voltage", ValueType::u16), 1, "V"));
    p.registers.push_back(with_decimals(reg("holding", 0x0001, "current", ValueType::u16), 2, "A"));
    const DecodedValue v = only(decode_values(p, holding(0x0000, {0x0898})));
    EXPECT_EQ(v.name, "voltage");
    EXPECT_EQ(v.value, "220.0");
}

TEST(Values, EmptyBlock) {
    EXPECT_TRUE(decode_values(meter(), holding(0x0000, {})).empty());
    EXPECT_TRUE(decode_values(Profile{}, holding(0xFFFF, {})).empty());
}

TEST(Values, EmptyProfileListsEverythingAsUnlisted) {
    const std::vector<DecodedValue> values = decode_values(Profile{}, holding(0x0000, {7, 8}));
    ASSERT_EQ(values.size(), 2U);
    EXPECT_EQ(values[1].value, "8");
    EXPECT_EQ(note_ids(values[1]), std::vector<std::string>{note_id::value_unlisted});
}

TEST(Values, BlockRunningPastTheLastAddressStopsThere) {
    const std::vector<DecodedValue> values =
        decode_values(meter(), holding(0xFFFE, {1, 2, 3, 4, 5, 6, 7, 8, 9, 10}));
    ASSERT_EQ(values.size(), 2U);
    EXPECT_EQ(values[0].address, 0xFFFE);
    EXPECT_EQ(values[0].name, "last");
    EXPECT_EQ(values[0].value, "1");
    EXPECT_EQ(values[1].address, 0xFFFF);
    EXPECT_EQ(values[1].value, "2");
    EXPECT_EQ(note_ids(values[1]), std::vector<std::string>{note_id::value_unlisted});
}

TEST(Values, BrokenProfilesDoNotCrash) {
    Profile p;
    // A 32-bit type given one register, and a string running past 0xFFFF.
    p.registers.push_back(reg("holding", 0x0000, "short32", ValueType::u32, 1));
    p.registers.push_back(reg("holding", 0xFFFF, "overflow", ValueType::string, 4));
    const DecodedValue v = only(decode_values(p, holding(0x0000, {5})));
    EXPECT_EQ(v.value, "");
    EXPECT_EQ(note_ids(v), std::vector<std::string>{note_id::value_partial});

    const DecodedValue tail = only(decode_values(p, holding(0xFFFF, {0x4142, 0x4344})));
    EXPECT_EQ(tail.name, "overflow");
    EXPECT_EQ(tail.raw, "0x4142");
    EXPECT_EQ(note_ids(tail), std::vector<std::string>{note_id::value_partial});
}

}  // namespace
}  // namespace rtuscope
