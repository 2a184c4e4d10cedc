// Profile files: what a correct file gives, every kind of mistake reported with its
// position, address formulas, and the bundled profiles loading cleanly.
#include <gtest/gtest.h>

#include <string>

#include "profiles/profile.hpp"
#include "profiles/profile_formula.hpp"

namespace rtuscope {
namespace {

ProfileLoad load(const std::string& text) {
    return load_profile_text(text, "test.toml");
}

// All problems, one per line, as `profiles check` prints them.
std::string problems(const ProfileLoad& l) {
    std::string out;
    for (const ProfileProblem& p : l.problems) out += p.to_string() + "\n";
    return out;
}

const char* const kDevice = "[device]\nname = \"t\"\n";

TEST(ProfileLoader, ReadsEveryField) {
    const auto l = load(R"([device]
name = "pdu-test"
title = "A PDU"
source = "manual 1.0"
line = "19200 8E1"
addresses = [1, 250]
broadcast = 255
exception_answers = false
max_registers = 100

[[function]]
code = 0x04
name = "Set coefficient"
request_length = 8
answer = "echo"
layout = "address_value"
table = "eeprom"

[[register]]
address = 0x0000
name = "voltage"
type = "u16"
decimals = 1
unit = "V"
access = "R"
range = [0.0, 300]
description = "present voltage"

[[register]]
address = 4
name = "energy"
type = "u32"
word_order = "low_first"
scale = 0.01
unit = "kWh"
access = "RW"
writes = { "0xAABB" = "clear" }

[[register]]
address = 6
name = "baud"
type = "enum"
values = { "0" = "1200", "0x03" = "9600" }

[[register]]
address = 7
name = "alarms"
type = "bits"
bits = { "0" = "over voltage", "15" = "fault" }

[[register]]
address = 8
name = "model"
type = "string"
length = 4

[[register]]
table = "eeprom"
address = 0x15
name = "coefficient"
decimals = 1
access = "W"
)");
    ASSERT_TRUE(l.profile) << problems(l);
    const Profile& p = *l.profile;
    EXPECT_EQ(p.name, "pdu-test");
    EXPECT_EQ(p.title, "A PDU");
    ASSERT_TRUE(p.line);
    EXPECT_EQ(p.line->baud, 19200U);
    EXPECT_EQ(p.line->format(), "8E1");
    EXPECT_EQ(p.first_address, 1);
    EXPECT_EQ(p.last_address, 250);
    EXPECT_EQ(p.broadcast, 255);
    EXPECT_FALSE(p.exception_answers);
    EXPECT_EQ(p.max_registers, 100);
    ASSERT_NE(p.function(0x04), nullptr);
    EXPECT_EQ(p.function(0x04)->answer, Answer::echo);
    EXPECT_EQ(p.function(0x04)->request_length.kind, LengthRule::Kind::fixed);
    EXPECT_EQ(p.function(0x04)->request_length.n, 8U);
    EXPECT_EQ(p.function(0x04)->device_table, "eeprom");
    EXPECT_EQ(p.function(0x05), nullptr);

    ASSERT_EQ(p.registers.size(), 6U);
    const Register* voltage = p.register_at("holding", 0);
    ASSERT_NE(voltage, nullptr);
    EXPECT_DOUBLE_EQ(voltage->scale, 0.1);
    EXPECT_EQ(voltage->decimals, 1);
    EXPECT_EQ(voltage->unit, "V");
    EXPECT_EQ(voltage->min, 0.0);
    EXPECT_EQ(voltage->max, 300.0);
    EXPECT_EQ(voltage->pos.line, 19);

    const Register* energy = p.register_at("holding", 4);
    ASSERT_NE(energy, nullptr);
    EXPECT_EQ(energy->length, 2);
    EXPECT_EQ(energy->word_order, WordOrder::cdab);
    EXPECT_EQ(energy->access, Access::read_write);
    EXPECT_EQ(energy->writes.at(0xAABB), "clear");
    EXPECT_EQ(p.register_covering("holding", 5), energy);
    EXPECT_EQ(p.register_at("holding", 5), nullptr);

    EXPECT_EQ(p.register_at("holding", 6)->labels.at(3), "9600");
    EXPECT_EQ(p.register_at("holding", 7)->labels.at(15), "fault");
    EXPECT_EQ(p.register_at("holding", 8)->length, 4);
    EXPECT_EQ(p.register_covering("holding", 11)->name, "model");
    EXPECT_EQ(p.register_covering("holding", 12), nullptr);
    EXPECT_EQ(p.register_at("eeprom", 0x15)->access, Access::write);
    EXPECT_EQ(p.register_at("input", 0), nullptr);
}

TEST(ProfileLoader, FormulaMakesOneRegisterPerCombination) {
    const auto l = load(std::string(kDevice) + R"(
[[register]]
formula = "(channel-1)*100 + (sensor-1)*2"
channel = [1, 18]
sensor = [1, 50]
name = "ch{channel}.s{sensor}"
type = "i16"
)");
    ASSERT_TRUE(l.profile) << problems(l);
    const Profile& p = *l.profile;
    EXPECT_EQ(p.registers.size(), 18U * 50U);
    EXPECT_EQ(p.register_at("holding", 0)->name, "ch1.s1");
    EXPECT_EQ(p.register_at("holding", 2)->name, "ch1.s2");
    EXPECT_EQ(p.register_at("holding", 102)->name, "ch2.s2");
    EXPECT_EQ(p.register_at("holding", 1798)->name, "ch18.s50");
    EXPECT_EQ(p.register_at("holding", 1), nullptr);  // the formula skips odd addresses
    EXPECT_EQ(p.register_at("holding", 1798)->type, ValueType::i16);
}

TEST(ProfileLoader, SixtyFourBitTypesTakeFourRegistersInAnyWordOrder) {
    const auto l = load(std::string(kDevice) + R"(
[[register]]
address = 0
name = "energy"
type = "u64"

[[register]]
address = 4
name = "offset"
type = "i64"
word_order = "low_first"

[[register]]
address = 8
name = "flow"
type = "f64"
word_order = "badc"

[[register]]
address = 12
name = "power"
type = "f32"
word_order = "dcba"

[[register]]
address = 14
name = "count"
type = "u32"
word_order = "cdab"
)");
    ASSERT_TRUE(l.profile) << problems(l);
    const Profile& p = *l.profile;
    const Register* energy = p.register_at("holding", 0);
    ASSERT_NE(energy, nullptr);
    EXPECT_EQ(energy->type, ValueType::u64);
    EXPECT_EQ(energy->length, 4);
    EXPECT_EQ(energy->word_order, WordOrder::abcd);
    EXPECT_EQ(p.register_covering("holding", 3), energy);
    EXPECT_EQ(p.register_at("holding", 4)->type, ValueType::i64);
    EXPECT_EQ(p.register_at("holding", 4)->word_order, WordOrder::cdab);
    EXPECT_EQ(p.register_at("holding", 8)->type, ValueType::f64);
    EXPECT_EQ(p.register_at("holding", 8)->word_order, WordOrder::badc);
    EXPECT_EQ(p.register_at("holding", 12)->word_order, WordOrder::dcba);
    EXPECT_EQ(p.register_at("holding", 12)->length, 2);
    EXPECT_EQ(p.register_at("holding", 14)->word_order, WordOrder::cdab);
}

struct BadCase {
    const char* what;
    std::string text;
    std::string expected;  // the whole `profiles check` output
};

void PrintTo(const BadCase& c, std::ostream* os) {
    *os << c.what;
}

class ProfileMistakes : public ::testing::TestWithParam<BadCase> {};

TEST_P(ProfileMistakes, AreReportedWithTheirPosition) {
    const auto l = load(GetParam().text);
    EXPECT_FALSE(l.profile);
    EXPECT_EQ(problems(l), GetParam().expected);
}

INSTANTIATE_TEST_SUITE_P(
    , ProfileMistakes,
    ::testing::Values(
        // TOML syntax errors: toml++'s first one, in plain words, at the place to look.
        BadCase{"toml_unclosed_string", "[device]\nname = \"t\nx = 1\n",
                "test.toml:2:8: a string is not closed: add the missing \" at the end of the "
                "value\n"},
        BadCase{"toml_unclosed_string_with_escaped_quotes",
                "[device]\nname = \"t\"\ntitle = \"the \\\"PDU\\\" meter\n",
                "test.toml:3:9: a string is not closed: add the missing \" at the end of the "
                "value\n"},
        BadCase{"toml_unclosed_literal_string", "[device]\nname = 't\n",
                "test.toml:2:8: a string is not closed: add the missing ' at the end of the "
                "value\n"},
        BadCase{"toml_unclosed_multi_line_string",
                "[device]\nname = \"t\"\ntitle = \"\"\"A\nmeter\n",
                "test.toml:3:9: a multi-line string is not closed: add the missing \"\"\" at its "
                "end\n"},
        BadCase{"toml_unclosed_header", std::string(kDevice) + "[[register]\naddress = 1\n",
                "test.toml:3:1: the table header [[register] is not closed: write "
                "[[register]]\n"},
        BadCase{"toml_missing_equals", "[device]\nname \"t\"\n",
                "test.toml:2:6: a key is not followed by =: write key = value\n"},
        BadCase{"toml_key_with_a_space", "[device]\nmax registers = 10\n",
                "test.toml:2:5: a key has a space in it, or no = after it: write key = value, and "
                "a key of several words in \"quotes\"\n"},
        BadCase{"toml_missing_value", "[device]\nname =\n",
                "test.toml:2:7: a key has no value after its =: write key = value\n"},
        BadCase{"toml_duplicate_key",
                std::string(kDevice) + "[[register]]\naddress = 1\nname = \"a\"\naddress = 2\n",
                "test.toml:6:1: the key \"address\" is given twice in one table (also at line 4): "
                "keep one\n"},
        BadCase{"toml_duplicate_table", std::string(kDevice) + "[device]\ntitle = \"x\"\n",
                "test.toml:3:1: the table [device] is given twice: put its keys under one "
                "[device]\n"},
        BadCase{"toml_bad_number", std::string(kDevice) + "[[register]]\naddress = 0x12G\n",
                "test.toml:4:15: a number has the character 'G' in it: write numbers like 42, "
                "0x2A or 0.5, and text in \"quotes\"\n"},
        BadCase{"toml_leading_zero", std::string(kDevice) + "[[register]]\naddress = 012\n",
                "test.toml:4:14: a number may not start with 0: write 12, or 0x12 for hex\n"},
        BadCase{"toml_bad_escape", "[device]\nname = \"t\"\nsource = \"C:\\manuals\"\n",
                "test.toml:3:14: a string has the unknown escape \\m: write \\\\ for a "
                "backslash, or put the text in 'single quotes', which keep backslashes as they "
                "are\n"},
        BadCase{"toml_unquoted_text", "[device]\nname = pdu\n",
                "test.toml:2:8: a value is not a number, true, false, an [array], a { table } "
                "or a \"string\": put text in quotes\n"},
        BadCase{"toml_array_without_comma", "[device]\nname = \"t\"\naddresses = [1 2]\n",
                "test.toml:3:16: an array needs a comma between its values and a ] at its end\n"},
        BadCase{"toml_inline_table_over_two_lines",
                std::string(kDevice) + "[[register]]\naddress = 1\nname = \"a\"\ntype = \"enum\"\n"
                                       "values = { \"0\" = \"off\",\n  \"1\" = \"on\" }\n",
                "test.toml:7:24: an inline table { ... } must end on the line where it starts: "
                "add the missing }\n"},
        // A mistake without plain words of its own keeps toml++'s.
        BadCase{"toml_other", "[device]\nname = \"t\"\naddress = 1__0\n",
                "test.toml:3:13: not valid TOML: error while parsing decimal integer: "
                "underscores may only follow digits\n"},
        BadCase{"unknown_type",
                std::string(kDevice) + "[[register]]\naddress = 1\nname = \"a\"\n"
                                       "type = \"u24\"\n",
                "test.toml:6:8: unknown type \"u24\" (u16, i16, u32, i32, f32, u64, i64, f64, "
                "bits, enum, string)\n"},
        BadCase{"unknown_word_order",
                std::string(kDevice) + "[[register]]\naddress = 1\nname = \"a\"\n"
                                       "type = \"f64\"\nword_order = \"bacd\"\n",
                "test.toml:7:14: unknown word_order \"bacd\" (abcd, cdab, badc, dcba, "
                "high_first (abcd), low_first (cdab))\n"},
        BadCase{"word_order_of_one_register",
                std::string(kDevice) + "[[register]]\naddress = 1\nname = \"a\"\n"
                                       "type = \"i16\"\nword_order = \"dcba\"\n",
                "test.toml:7:14: word_order is only for u32, i32, f32, u64, i64 and f64\n"},
        // A 64-bit value covers four registers.
        BadCase{"overlap_of_a_64_bit_value",
                std::string(kDevice) + "[[register]]\naddress = 0\nname = \"total\"\n"
                                       "type = \"u64\"\n\n[[register]]\naddress = 3\n"
                                       "name = \"next\"\n",
                "test.toml:8:1: register \"next\" (0x0003) overlaps \"total\" (0x0000, 4 "
                "registers, line 3) in table holding\n"},
        BadCase{"overlap",
                std::string(kDevice) +
                    "[[register]]\naddress = 4\nname = \"energy\"\ntype = \"u32\"\n\n"
                    "[[register]]\naddress = 5\nname = \"low\"\n",
                "test.toml:8:1: register \"low\" (0x0005) overlaps \"energy\" (0x0004, 2 "
                "registers, line 3) in table holding\n"},
        BadCase{"duplicate_name",
                std::string(kDevice) + "[[register]]\naddress = 1\nname = \"a\"\n\n"
                                       "[[register]]\naddress = 2\nname = \"a\"\n",
                "test.toml:7:1: duplicate register name \"a\" (also at line 3)\n"},
        BadCase{"address_out_of_range",
                std::string(kDevice) + "[[register]]\naddress = 70000\nname = \"a\"\n",
                "test.toml:4:11: address must be an integer from 0 to 65535\n"},
        BadCase{"runs_past_the_end",
                std::string(kDevice) + "[[register]]\naddress = 0xFFFF\nname = \"a\"\n"
                                       "type = \"f32\"\n",
                "test.toml:3:1: register \"a\" at 0xFFFF takes 2 registers and runs past "
                "address 0xFFFF\n"},
        BadCase{"bad_formula",
                std::string(kDevice) + "[[register]]\nformula = \"(channel-1*100\"\n"
                                       "channel = [1, 2]\nname = \"c{channel}\"\n",
                "test.toml:4:11: bad formula: expected ')' at character 15\n"},
        BadCase{"formula_without_range",
                std::string(kDevice) + "[[register]]\nformula = \"(ch-1)*10 + s\"\n"
                                       "ch = [1, 2]\nname = \"c{ch}.{s}\"\n",
                "test.toml:4:11: formula variable \"s\" needs a range: s = [first, last]\n"},
        BadCase{"formula_out_of_range",
                std::string(kDevice) + "[[register]]\nformula = \"ch*1000\"\n"
                                       "ch = [1, 100]\nname = \"c{ch}\"\n",
                "test.toml:4:11: formula gives address 66000 for c66, outside 0-65535\n"},
        BadCase{"formula_name_without_variable",
                std::string(kDevice) + "[[register]]\nformula = \"ch*2\"\n"
                                       "ch = [1, 3]\nname = \"channel\"\n",
                "test.toml:6:8: name \"channel\" must contain {ch}: each register of a formula "
                "needs its own name\n"},
        BadCase{"unknown_keys_everywhere",
                "[device]\nname = \"t\"\nbaud = 9600\n\n[[register]]\naddress = 1\nname = "
                "\"a\"\nunits = \"V\"\n\n[extra]\n",
                "test.toml:3:1: unknown key \"baud\" in [device] (known: name, title, source, "
                "line, addresses, broadcast, exception_answers, max_registers)\n"
                "test.toml:8:1: unknown key \"units\" in [[register]]\n"
                "test.toml:10:2: unknown key \"extra\" at the top level (known: device, "
                "function, register)\n"},
        BadCase{"home_assistant_classes",
                std::string(kDevice) +
                    "[[register]]\naddress = 1\nname = \"a\"\n"
                    "home_assistant = { device_class = \"Energy\", state_class = \"sum\", x = 1 }\n"
                    "[[register]]\naddress = 2\nname = \"b\"\nhome_assistant = \"energy\"\n",
                "test.toml:6:35: device_class \"Energy\" must be lower-case letters and _, as Home "
                "Assistant names them (\"energy\", \"power\"), or \"\"\n"
                "test.toml:6:59: state_class \"sum\" must be \"measurement\", \"total\", "
                "\"total_increasing\" or \"\"\n"
                "test.toml:6:66: unknown key \"x\" in home_assistant (device_class, state_class)\n"
                "test.toml:10:18: home_assistant must be a table like { device_class = \"energy\" }\n"},
        BadCase{"several_mistakes_in_one_register",
                std::string(kDevice) + "[[register]]\naddress = 1\nname = \"a b\"\n"
                                       "access = \"RO\"\nscale = 0.1\ndecimals = 1\n",
                "test.toml:5:8: name \"a b\" must be letters, digits, _ . -\n"
                "test.toml:6:10: access \"RO\" must be \"R\", \"W\" or \"RW\"\n"
                "test.toml:8:12: give scale or decimals, not both\n"},
        // A register with a mistake of its own still overlaps, and keeps its name.
        BadCase{"overlap_of_a_register_with_another_mistake",
                std::string(kDevice) +
                    "[[register]]\naddress = 4\nname = \"energy\"\ntype = \"u32\"\n\n"
                    "[[register]]\naddress = 5\nname = \"low\"\naccess = \"RO\"\n\n"
                    "[[register]]\naddress = 9\nname = \"low\"\nunit = 1\n",
                "test.toml:8:1: register \"low\" (0x0005) overlaps \"energy\" (0x0004, 2 "
                "registers, line 3) in table holding\n"
                "test.toml:11:10: access \"RO\" must be \"R\", \"W\" or \"RW\"\n"
                "test.toml:13:1: duplicate register name \"low\" (also at line 8)\n"
                "test.toml:16:8: unit must be a string\n"},
        // A string covers the registers after it, not only the next one.
        BadCase{"overlaps_past_the_next_register",
                std::string(kDevice) +
                    "[[register]]\naddress = 0\nname = \"model\"\ntype = \"string\"\n"
                    "length = 8\n\n[[register]]\naddress = 2\nname = \"serial\"\n\n"
                    "[[register]]\naddress = 5\nname = \"firmware\"\n",
                "test.toml:9:1: register \"serial\" (0x0002) overlaps \"model\" (0x0000, 8 "
                "registers, line 3) in table holding\n"
                "test.toml:13:1: register \"firmware\" (0x0005) overlaps \"model\" (0x0000, 8 "
                "registers, line 3) in table holding\n"},
        // Whose length is unknown overlaps nothing, but its name is still checked.
        BadCase{"unknown_type_keeps_its_name",
                std::string(kDevice) + "[[register]]\naddress = 0\nname = \"a\"\ntype = \"u128\"\n\n"
                                       "[[register]]\naddress = 1\nname = \"a\"\n",
                "test.toml:6:8: unknown type \"u128\" (u16, i16, u32, i32, f32, u64, i64, "
                "f64, bits, enum, string)\n"
                "test.toml:8:1: duplicate register name \"a\" (also at line 3)\n"},
        // Every key of a [[function]] is checked, whatever is wrong with its code.
        BadCase{"function_without_code",
                std::string(kDevice) + "[[function]]\nanswer = \"never\"\n"
                                       "table = \"eeprom\"\n\n[[register]]\ntable = \"eeprom\"\n"
                                       "address = 1\nname = \"a\"\n",
                "test.toml:3:1: [[function]] needs a code\n"
                "test.toml:4:10: answer \"never\" must be \"standard\", \"echo\" or \"none\"\n"},
        BadCase{"bad_name_and_line", "[device]\nname = \"My PDU\"\nline = \"9600 9X1\"\n",
                "test.toml:2:8: name \"My PDU\" must be lower case letters, digits and -\n"
                "test.toml:3:8: bad line format \"9X1\" (expected data bits 5-8, parity N/E/O, "
                "stop bits 1-2, e.g. 8N1 or 8E1)\n"},
        BadCase{"missing_device", "[[register]]\naddress = 1\nname = \"a\"\n",
                "test.toml:1:1: missing [device] table\n"},
        BadCase{"unknown_table",
                std::string(kDevice) + "[[register]]\ntable = \"eeprom\"\naddress = 1\n"
                                       "name = \"a\"\n",
                "test.toml:4:9: unknown table \"eeprom\" (holding, input, coil, discrete, or "
                "the table of a [[function]] defined above)\n"},
        BadCase{"enum_without_values",
                std::string(kDevice) + "[[register]]\naddress = 1\nname = \"a\"\n"
                                       "type = \"enum\"\n",
                "test.toml:3:1: enum register \"a\" needs values\n"},
        BadCase{"bad_enum_key",
                std::string(kDevice) + "[[register]]\naddress = 1\nname = \"a\"\n"
                                       "type = \"enum\"\nvalues = { \"one\" = \"1\" }\n",
                "test.toml:7:12: values key \"one\" must be a number from 0 to 65535\n"},
        BadCase{"duplicate_function",
                std::string(kDevice) + "[[function]]\ncode = 4\n\n[[function]]\ncode = 0x04\n",
                "test.toml:7:8: function 0x04 is defined twice\n"}),
    [](const ::testing::TestParamInfo<BadCase>& param) { return std::string(param.param.what); });

TEST(ProfileLoader, MissingAndDirectoryFilesAreOneLine) {
    const auto missing = load_profile_file("no/such/profile.toml");
    EXPECT_FALSE(missing.profile);
    EXPECT_EQ(problems(missing), "no/such/profile.toml: cannot open: No such file or directory\n");
    const auto dir = load_profile_file(RTUSCOPE_SOURCE_DIR);
    EXPECT_FALSE(dir.profile);
    EXPECT_EQ(problems(dir), std::string(RTUSCOPE_SOURCE_DIR) + ": is a directory\n");
}

TEST(ProfileLoader, HugeFormulaRangeIsRefused) {
    const auto l = load(std::string(kDevice) +
                        "[[register]]\nformula = \"a+b\"\n"
                        "a = [0, 100000]\nb = [0, 100000]\n"
                        "name = \"r{a}.{b}\"\n");
    EXPECT_FALSE(l.profile);
    EXPECT_EQ(problems(l),
              "test.toml:4:11: the formula's ranges give more than 65536 "
              "registers\n");
}

TEST(ProfileFormula, EvaluatesWithPrecedenceAndParentheses) {
    auto f = parse_formula("(channel-1)*100 + (sensor-1)*2");
    ASSERT_TRUE(f) << f.error().message;
    EXPECT_EQ(f->variables(), (std::vector<std::string>{"channel", "sensor"}));
    EXPECT_EQ(*f->evaluate({{"channel", 18}, {"sensor", 50}}), 1798);
    EXPECT_EQ(*parse_formula("2+3*4")->evaluate({}), 14);
    EXPECT_EQ(*parse_formula("-(7/2)")->evaluate({}), -3);
    EXPECT_FALSE(parse_formula("1/0")->evaluate({}));
    EXPECT_FALSE(parse_formula("x+1")->evaluate({}));
}

TEST(ProfileFormula, SyntaxErrorsNameTheCharacter) {
    EXPECT_EQ(parse_formula("1 + * 2").error().message, "unexpected '*' at character 5");
    EXPECT_EQ(parse_formula("1 +").error().message, "the formula ends too early");
    EXPECT_EQ(parse_formula("(1").error().message, "expected ')' at character 3");
    EXPECT_EQ(parse_formula("2 x").error().message, "unexpected 'x' at character 3");
    EXPECT_EQ(parse_formula("99999999999").error().message, "number at character 1 is too large");
    EXPECT_EQ(parse_formula(std::string(500, '(') + "1" + std::string(500, ')')).error().message,
              "the formula nests too deeply");
}

TEST(BundledProfiles, AllLoadWithoutProblems) {
    std::string all;
    for (const ProfileProblem& p : bundled_profile_problems()) all += p.to_string() + "\n";
    EXPECT_EQ(all, "");
    EXPECT_EQ(bundled_profile_file_count(), 4U);
    EXPECT_EQ(bundled_profiles().size(), 4U);
}

}  // namespace
}  // namespace rtuscope
