// The text on a terminal: values packed to its width, frame lines cut with "…" (the
// summary first, notes kept on a line of their own), --hex wrapped, --no-values, and the
// columns aligned past 99,999 records.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "input/sources.hpp"
#include "output/sinks.hpp"
#include "pipeline.hpp"
#include "profiles/bus.hpp"
#include "util/terminal.hpp"

namespace rtuscope {
namespace {

TEST(Terminal, DisplayWidthSkipsColoursAndCountsCharacters) {
    EXPECT_EQ(display_width("abc"), 3U);
    EXPECT_EQ(display_width("\x1b[36m◀\x1b[0m x"), 3U);
    EXPECT_EQ(display_width("616.8 µW/cm²"), 12U);
    EXPECT_EQ(display_width("电压"), 4U);  // East Asian characters take two columns
    EXPECT_EQ(display_width("\xFF"), 1U);  // a byte that is no UTF-8
}

TEST(Terminal, CutToWidthEndsWithAnEllipsisAndClosesTheColour) {
    std::string line = "0123456789";
    cut_to_width(line, 10);
    EXPECT_EQ(line, "0123456789");
    cut_to_width(line, 6);
    EXPECT_EQ(line, "01234…");
    std::string painted = "ab \x1b[33m! a long note\x1b[0m";
    cut_to_width(painted, 8);
    EXPECT_EQ(painted, "ab \x1b[33m! a …\x1b[0m");
    EXPECT_EQ(display_width(painted), 8U);
    std::string wide = "x电压电压";
    cut_to_width(wide, 5);
    EXPECT_EQ(wide, "x电…");  // a two-column character is never cut in half
    std::string after_first = "keep\nabcdefgh";
    cut_to_width(after_first, 4, 5);
    EXPECT_EQ(after_first, "keep\nabc…");
}

// The PDU's whole register map (29 registers, 28 values), its answer, a write and its
// echo; the answer with a bad CRC in a line of its own.
const char* const kPdu =
    "01 03 00 00 00 1D 85 C3\n"
    "01 03 3A 08 9D 00 96 01 46 03 D9 00 00 30 39 00 01 00 03 00 A0 0A 50 06 E0 00 FF 00 "
    "00 01 C2 FF CE 03 84 00 64 00 EB 01 C4 00 F1 01 C0 FF E7 02 5B 00 DC 01 F4 00 D9 02 03 "
    "00 00 00 00 16 CA\n";

std::string text_of(const std::string& input, TextOptions options) {
    Bus bus;
    EXPECT_TRUE(bus.assign(1, "pdu485"));
    char* buffer = nullptr;
    std::size_t size = 0;
    std::FILE* out = open_memstream(&buffer, &size);
    {
        auto source = source_from_memory(input, "mem", InputFormat::automatic);
        EXPECT_TRUE(source);
        PipelineOptions pipeline;
        pipeline.bus = &bus;
        auto sink = make_text_sink(out, options);
        EXPECT_TRUE(run_pipeline(**source, pipeline, *sink));
    }
    std::fclose(out);
    std::string text(buffer, size);
    std::free(buffer);
    return text;
}

std::vector<std::string> lines_of(const std::string& text) {
    std::vector<std::string> lines;
    for (std::size_t at = 0; at < text.size();) {
        const auto nl = text.find('\n', at);
        lines.push_back(text.substr(at, nl - at));
        at = nl + 1;
    }
    return lines;
}

// The lines of the records: after the header, before the closing summary.
std::vector<std::string> record_lines(const std::string& text) {
    std::vector<std::string> lines = lines_of(text);
    std::vector<std::string> records;
    for (std::size_t i = 2; i < lines.size() && !lines[i].starts_with("-- "); ++i) {
        records.push_back(lines[i]);
    }
    return records;
}

TEST(TextWidth, OneValuePerLineWithoutAWidth) {
    const std::vector<std::string> lines = record_lines(text_of(kPdu, TextOptions{}));
    ASSERT_EQ(lines.size(), 2U + 28U);  // the request, the answer, one line per value
    EXPECT_EQ(lines[2], std::string(28, ' ') + "voltage          = 220.5 V (raw 0x089D)");
    EXPECT_GT(display_width(lines[1]), 100U);  // the answer's register list, whole
}

TEST(TextWidth, ValuesPackedSideBySideAtTabStops) {
    TextOptions options;
    options.width = 100;
    const std::vector<std::string> lines = record_lines(text_of(kPdu, options));
    ASSERT_GE(lines.size(), 4U);
    ASSERT_LE(lines.size(), 2U + 14U);  // at least two values a line
    EXPECT_EQ(lines[2], std::string(28, ' ') +
                            "voltage = 220.5 V   current = 1.50 A    power = 326 W");
    std::size_t values = 0;
    for (const std::string& line : lines) {
        EXPECT_LE(display_width(line), 100U) << line;
        for (std::size_t at = line.find(" = "); at != std::string::npos;
             at = line.find(" = ", at + 1)) {
            ++values;
        }
    }
    EXPECT_EQ(values, 28U);  // every value is there
    // Each value starts at the indent or at a tab stop, every 10 columns from it.
    for (std::size_t i = 2; i < lines.size(); ++i) {
        for (std::size_t at = 28; at < lines[i].size(); ++at) {
            if (lines[i][at - 1] == ' ' && lines[i][at] != ' ' && lines[i][at - 2] == ' ' &&
                lines[i].compare(at, 2, "= ") != 0 && lines[i][at - 2] != '=') {
                EXPECT_EQ((display_width(lines[i].substr(0, at)) - 28) % 10, 0U) << lines[i];
            }
        }
    }
}

TEST(TextWidth, AFrameLineLosesItsSummaryFirstAndKeepsItsNotes) {
    TextOptions options;
    options.width = 90;
    // A read of 2 registers answered with 1: the answer's note does not fit beside it.
    const std::string input =
        "01 03 00 00 00 02 C4 0B\n"
        "01 03 02 08 9D 7E 2D\n";
    const std::vector<std::string> lines = record_lines(text_of(input, options));
    ASSERT_EQ(lines.size(), 4U) << text_of(input, options);
    EXPECT_TRUE(lines[1].ends_with("answers #1") || lines[1].find("after #1") != std::string::npos)
        << lines[1];
    EXPECT_EQ(lines[2], std::string(28, ' ') + "! byte count 2, 2 registers asked need 4");
    for (const std::string& line : lines) EXPECT_LE(display_width(line), 90U) << line;

    options.width = 120;
    const std::vector<std::string> wide = record_lines(text_of(kPdu, options));
    // 29 registers do not fit: their list is cut, what the answer answers stays.
    EXPECT_TRUE(wide[1].ends_with("…  answers #1")) << wide[1];
    EXPECT_EQ(display_width(wide[1]), 120U) << wide[1];
}

TEST(TextWidth, HexWrapsUnderTheFrame) {
    TextOptions options;
    options.width = 80;
    options.hex = true;
    const std::vector<std::string> lines = record_lines(text_of(kPdu, options));
    // The 63 bytes of the answer at 17 a line (52 columns after the indent): 4 lines.
    ASSERT_GE(lines.size(), 4U);
    EXPECT_EQ(lines[1], std::string(28, ' ') + "01 03 00 00 00 1D 85 C3");  // the request's
    ASSERT_TRUE(lines[2].starts_with("    2 ")) << lines[2];
    std::size_t hex_lines = 0;
    for (std::size_t i = 3; i < lines.size() && lines[i].find(" = ") == std::string::npos; ++i) {
        ++hex_lines;
        EXPECT_LE(display_width(lines[i]), 80U) << lines[i];
    }
    EXPECT_EQ(hex_lines, 4U);
    EXPECT_EQ(lines[3], std::string(28, ' ') + "01 03 3A 08 9D 00 96 01 46 03 D9 00 00 30 39 00 01");
}

TEST(TextWidth, NoValuesHidesThem) {
    TextOptions options;
    options.values = false;
    const std::vector<std::string> lines = record_lines(text_of(kPdu, options));
    EXPECT_EQ(lines.size(), 2U);
}

TEST(TextWidth, ColumnsStayAlignedPast99999Records) {
    // 100,001 requests for one register of the PDU, each answered: records 99,999 to
    // 100,002 straddle the column's growth.
    std::string input;
    for (int i = 0; i < 50'001; ++i) {
        input += "01 03 00 00 00 01 84 0A\n01 03 02 08 9D 7E 2D\n";
    }
    TextOptions options;
    options.width = 100;
    const std::vector<std::string> lines = record_lines(text_of(input, options));
    // Per answer: its line, then its value under it; the function column, the summary
    // and the value move one column right together once the number has six digits.
    const auto column_of = [](const std::string& line, const char* text) {
        return display_width(line.substr(0, line.find(text)));
    };
    const auto function_at = [&](const std::string& line) { return column_of(line, "Read Holding"); };
    const auto value_at = [&](const std::string& line) { return column_of(line, "voltage"); };
    // Three lines a pair: the request, the answer, its value. Records 99,997 and 99,998
    // are pair 49,998 (from 0).
    const std::size_t before = 3 * 49'998;
    ASSERT_GT(lines.size(), before + 5);
    EXPECT_TRUE(lines[before + 1].starts_with("99998 ")) << lines[before + 1];
    EXPECT_EQ(value_at(lines[before + 2]), function_at(lines[before + 1]) - 1);
    EXPECT_TRUE(lines[before + 4].starts_with("100000 ")) << lines[before + 4];
    EXPECT_EQ(function_at(lines[before + 4]), function_at(lines[before + 1]) + 1);
    EXPECT_EQ(value_at(lines[before + 5]), function_at(lines[before + 4]) - 1);
    EXPECT_EQ(function_at(lines[lines.size() - 2]), function_at(lines[before + 4]));
}

}  // namespace
}  // namespace rtuscope
