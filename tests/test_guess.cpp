// --guess: the readings of registers no profile covers (profiles/guess.hpp), and the one
// line a register's readings make in the text output (output/record_text.hpp).
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "output/record_text.hpp"
#include "profiles/guess.hpp"
#include "util/text.hpp"

namespace rtuscope {
namespace {

DataBlock holding_block(std::uint16_t start, std::vector<std::uint16_t> words, bool write = false) {
    DataBlock block;
    block.table = DataTable::holding_registers;
    block.start = start;
    block.values = std::move(words);
    block.write = write;
    return block;
}

std::span<const GuessedReading> all(const ReusedList<GuessedReading>& guesses) {
    return guesses;
}

// "0x0010 u16 16752" for each reading, to compare lists at a glance.
std::vector<std::string> listed(const ReusedList<GuessedReading>& guesses) {
    std::vector<std::string> out;
    for (const GuessedReading& g : guesses) {
        std::string line;
        append_hex4(line, g.address);
        line += std::string(" ") + reading_name(g.reading) + " " + g.value + " [" + g.raw + "]";
        out.push_back(line);
    }
    return out;
}

TEST(GuessReadings, OneRegisterAsUnsignedAndSignedOnlyWhenNegative) {
    EXPECT_EQ(read_words(GuessType::u16, 0xFF38), "65336");
    EXPECT_EQ(read_words(GuessType::i16, 0xFF38), "-200");
    EXPECT_EQ(read_words(GuessType::i16, 0x8000), "-32768");
    EXPECT_EQ(read_words(GuessType::u16, 0x7FFF), "32767");
    EXPECT_EQ(read_words(GuessType::i16, 0x7FFF), std::nullopt);  // the same as its u16
    EXPECT_EQ(read_words(GuessType::i16, 0x0000), std::nullopt);
}

TEST(GuessReadings, TwoRegistersAsU32InBothWordOrders) {
    EXPECT_EQ(read_words(GuessType::u32_abcd, 0x0001, 0x0002), "65538");
    EXPECT_EQ(read_words(GuessType::u32_cdab, 0x0001, 0x0002), "131073");
    EXPECT_EQ(read_words(GuessType::u32_abcd, 0xFFFF, 0xFFFF), "4294967295");
}

TEST(GuessReadings, FifteenAsF32InEitherWordOrder) {
    EXPECT_EQ(read_words(GuessType::f32_abcd, 0x4170, 0x0000), "15.0");
    EXPECT_EQ(read_words(GuessType::f32_cdab, 0x0000, 0x4170), "15.0");
    // The other order of the same words is a denormal: left out.
    EXPECT_EQ(read_words(GuessType::f32_cdab, 0x4170, 0x0000), std::nullopt);
    EXPECT_EQ(read_words(GuessType::f32_abcd, 0x0000, 0x4170), std::nullopt);
    EXPECT_EQ(read_words(GuessType::f32_abcd, 0xC148, 0x0000), "-12.5");
    EXPECT_EQ(read_words(GuessType::f32_abcd, 0x3DCC, 0xCCCD), "0.1");
}

TEST(GuessReadings, ImplausibleFloatsAreLeftOut) {
    EXPECT_EQ(read_words(GuessType::f32_abcd, 0x7FC0, 0x0000), std::nullopt);  // NaN
    EXPECT_EQ(read_words(GuessType::f32_abcd, 0x7F80, 0x0000), std::nullopt);  // +inf
    EXPECT_EQ(read_words(GuessType::f32_abcd, 0xFF80, 0x0000), std::nullopt);  // -inf
    EXPECT_EQ(read_words(GuessType::f32_abcd, 0x0001, 0x0000), std::nullopt);  // denormal
    EXPECT_EQ(read_words(GuessType::f32_abcd, 0x6000, 0x0000), std::nullopt);  // 3.7e19
    EXPECT_EQ(read_words(GuessType::f32_abcd, 0x3000, 0x0000), std::nullopt);  // 4.7e-10
    EXPECT_EQ(read_words(GuessType::f32_abcd, 0x0000, 0x0000), "0.0");
    EXPECT_EQ(read_words(GuessType::f32_abcd, 0x8000, 0x0000), "0.0");  // -0: no sign
    EXPECT_TRUE(plausible_float(1e9F));
    EXPECT_TRUE(plausible_float(-1e-6F));
    EXPECT_FALSE(plausible_float(2e9F));
    EXPECT_FALSE(plausible_float(5e-7F));
}

TEST(GuessReadings, EveryRegisterAndEachAdjacentPairOfABlockWithoutProfile) {
    ReusedList<GuessedReading> out;
    guess_readings(nullptr, holding_block(0x0010, {0x0000, 0x4170, 0xFF38}), out);
    EXPECT_EQ(listed(out), (std::vector<std::string>{
                               "0x0010 u16 0 [0x0000]",
                               "0x0010 u32/abcd 16752 [0x0000 0x4170]",
                               "0x0010 u32/cdab 1097859072 [0x0000 0x4170]",
                               "0x0010 f32/cdab 15.0 [0x0000 0x4170]",
                               "0x0011 u16 16752 [0x4170]",
                               "0x0011 u32/abcd 1097924408 [0x4170 0xFF38]",
                               "0x0011 u32/cdab 4281876848 [0x4170 0xFF38]",
                               "0x0011 f32/abcd 15.062309 [0x4170 0xFF38]",
                               "0x0012 u16 65336 [0xFF38]",
                               "0x0012 i16 -200 [0xFF38]",
                           }));
}

TEST(GuessReadings, RegistersTheProfileCoversAreNotGuessed) {
    Profile p;
    p.name = "meter";
    Register voltage;
    voltage.table = "holding";
    voltage.address = 0x0011;
    voltage.name = "voltage";
    p.registers.push_back(voltage);
    ReusedList<GuessedReading> out;
    guess_readings(&p, holding_block(0x0010, {0x0000, 0x4170, 0xFF38, 0x0001}), out);
    // 0x0011 is the profile's: neither it nor a pair with it is guessed.
    EXPECT_EQ(listed(out), (std::vector<std::string>{
                               "0x0010 u16 0 [0x0000]",
                               "0x0012 u16 65336 [0xFF38]",
                               "0x0012 i16 -200 [0xFF38]",
                               "0x0012 u32/abcd 4281860097 [0xFF38 0x0001]",
                               "0x0012 u32/cdab 130872 [0xFF38 0x0001]",
                               "0x0013 u16 1 [0x0001]",
                           }));
}

TEST(GuessReadings, WritesAreGuessedBitsAndOwnTablesAreNot) {
    ReusedList<GuessedReading> out;
    guess_readings(nullptr, holding_block(0x0004, {0x0003}, true), out);
    EXPECT_EQ(listed(out), (std::vector<std::string>{"0x0004 u16 3 [0x0003]"}));
    out.clear();
    DataBlock coils = holding_block(0, {1, 0, 1});
    coils.table = DataTable::coils;
    guess_readings(nullptr, coils, out);
    DataBlock own = holding_block(0, {0x4170, 0x0000});
    own.custom_table = "config";
    guess_readings(nullptr, own, out);
    EXPECT_TRUE(out.empty());
}

TEST(GuessReadings, ABlockEndingAtTheLastAddressDoesNotWrap) {
    ReusedList<GuessedReading> out;
    guess_readings(nullptr, holding_block(0xFFFF, {0x4170, 0x0000}), out);
    EXPECT_EQ(listed(out), (std::vector<std::string>{"0xFFFF u16 16752 [0x4170]"}));
}

TEST(GuessLine, ARegisterWithTheNextOnOneLine) {
    ReusedList<GuessedReading> out;
    guess_readings(nullptr, holding_block(0x0010, {0xFF38, 0x4170}), out);
    std::string text;
    const std::size_t end = append_guess_line(text, all(out), 0);
    EXPECT_EQ(text,
              "guess 0x0010 (0xFF38): u16 65336, i16 -200 | with 0x0011: u32/abcd 4281876848, "
              "u32/cdab 1097924408, f32/cdab 15.062309");
    text.clear();
    EXPECT_EQ(append_guess_line(text, all(out), end), out.size());
    EXPECT_EQ(text, "guess 0x0011 (0x4170): u16 16752");
}

TEST(GuessLine, RegistersAllZeroInARowMakeOneLine) {
    ReusedList<GuessedReading> out;
    guess_readings(nullptr, holding_block(0x0010, {0x0000, 0x0000, 0x0000, 0x0005}), out);
    std::string text;
    std::size_t i = append_guess_line(text, all(out), 0);
    EXPECT_EQ(text, "guess 0x0010..0x0011: 2 registers, all 0");
    text.clear();
    i = append_guess_line(text, all(out), i);
    EXPECT_EQ(text,
              "guess 0x0012 (0x0000): u16 0 | with 0x0013: u32/abcd 5, u32/cdab 327680");
    text.clear();
    EXPECT_EQ(append_guess_line(text, all(out), i), out.size());
    EXPECT_EQ(text, "guess 0x0013 (0x0005): u16 5");
}

}  // namespace
}  // namespace rtuscope
