#include <fcntl.h>
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "input/capture_writer.hpp"
#include "input/sources.hpp"
#include "support.hpp"

namespace rtuscope {
namespace {

using Bytes = std::vector<std::uint8_t>;

struct Drained {
    std::vector<Chunk> chunks;
    std::optional<Error> error;
};

Drained drain(ChunkSource& source) {
    Drained d;
    for (;;) {
        Chunk chunk;
        Result<bool> more = source.next(chunk);
        if (!more) {
            d.error = more.error();
            return d;
        }
        if (!*more) return d;
        d.chunks.push_back(std::move(chunk));
    }
}

std::unique_ptr<ChunkSource> from_memory(std::string text, InputFormat format,
                                         std::string name = "cap.rtucap") {
    auto source = source_from_memory(std::move(text), std::move(name), format);
    if (!source) {
        ADD_FAILURE() << source.error().to_string();
        return nullptr;
    }
    return std::move(*source);
}

Drained read_all(std::string text, InputFormat format, std::string name = "cap.rtucap") {
    auto source = from_memory(std::move(text), format, std::move(name));
    if (!source) return {};
    return drain(*source);
}

// The first error the text gives, whether at open or while reading.
std::string error_text(std::string text, InputFormat format = InputFormat::capture) {
    auto source = source_from_memory(std::move(text), "cap.rtucap", format);
    if (!source) return source.error().to_string();
    Drained d = drain(**source);
    return d.error ? d.error->to_string() : "(no error)";
}

std::string capture(const std::string& body) {
    return "# rtuscope capture v1\n" + body;
}

using test::TempDir;

// --- formats and names ------------------------------------------------------------------

TEST(SourcesInputFormat, ParsesNamesAndRejectsOthers) {
    EXPECT_EQ(*parse_input_format("capture"), InputFormat::capture);
    EXPECT_EQ(*parse_input_format("raw"), InputFormat::raw);
    EXPECT_EQ(*parse_input_format("hex"), InputFormat::hex);
    EXPECT_EQ(*parse_input_format("auto"), InputFormat::automatic);
    EXPECT_EQ(*parse_input_format("pcap"), InputFormat::pcap);
    auto bad = parse_input_format("pcapx");
    ASSERT_FALSE(bad.ok());
    EXPECT_EQ(bad.error().to_string(),
              "unknown input format \"pcapx\" (expected auto, capture, raw, hex or pcap)");
    EXPECT_STREQ(to_string(InputFormat::capture), "capture");
    EXPECT_STREQ(to_string(InputFormat::raw), "raw");
    EXPECT_STREQ(to_string(InputFormat::hex), "hex");
    EXPECT_STREQ(to_string(InputFormat::automatic), "auto");
}

// --- capture format ---------------------------------------------------------------------

// A capture's times are Unix time from 2001 on, relative seconds below.
TEST(CaptureReader, TheFirstTimestampTellsWhatTheTimesAre) {
    for (const auto& [first, base] :
         {std::pair("1763798400.022360", TimeBase::unix_time),
          std::pair("0.022360", TimeBase::relative), std::pair("bad", TimeBase::relative)}) {
        SCOPED_TRACE(first);
        auto source = from_memory(
            capture(std::string("# serial 9600 8N1\n") + first + " 01 03 00 00 00 02 C4 0B\n"),
            InputFormat::capture);
        ASSERT_TRUE(source);
        EXPECT_EQ(source->info().time_base, base);
    }
}

TEST(CaptureReader, ReadsHeaderAndDataLines) {
    auto source = from_memory(capture("# serial 19200 8E1\n"
                                      "# a comment\n"
                                      "\n"
                                      "1763798400.022360 01 03 00 00 00 02 C4 0B\n"
                                      "1763798400.038384 01 03 02 17 F8 B6 36\n"),
                              InputFormat::capture);
    ASSERT_TRUE(source);
    const SourceInfo& info = source->info();
    EXPECT_EQ(info.name, "cap.rtucap");
    EXPECT_EQ(info.format, "capture");
    EXPECT_TRUE(info.timed);
    EXPECT_EQ(info.time_base, TimeBase::unix_time);
    EXPECT_FALSE(info.chunk_time_is_start);
    ASSERT_TRUE(info.line.has_value());
    EXPECT_EQ(info.line->baud, 19200U);
    EXPECT_EQ(info.line->data_bits, 8);
    EXPECT_EQ(info.line->parity, 'E');
    EXPECT_EQ(info.line->stop_bits, 1);

    Drained d = drain(*source);
    ASSERT_FALSE(d.error) << d.error->to_string();
    ASSERT_EQ(d.chunks.size(), 2U);
    EXPECT_EQ(d.chunks[0].time, 1763798400022360000);
    EXPECT_EQ(d.chunks[0].bytes, (Bytes{0x01, 0x03, 0x00, 0x00, 0x00, 0x02, 0xC4, 0x0B}));
    EXPECT_EQ(d.chunks[0].source_line, 5);
    EXPECT_EQ(d.chunks[0].channel, "");
    EXPECT_EQ(d.chunks[1].time, 1763798400038384000);
    EXPECT_EQ(d.chunks[1].bytes, (Bytes{0x01, 0x03, 0x02, 0x17, 0xF8, 0xB6, 0x36}));
    EXPECT_EQ(d.chunks[1].source_line, 6);
}

TEST(CaptureReader, NoSerialLineLeavesLineSettingsUnset) {
    auto source = from_memory(capture("0.001 01\n"), InputFormat::capture);
    ASSERT_TRUE(source);
    EXPECT_FALSE(source->info().line.has_value());
}

TEST(CaptureReader, HeaderOnlyCaptureHasNoChunks) {
    Drained d = read_all(capture("# serial 9600 8N1\n"), InputFormat::capture);
    EXPECT_FALSE(d.error);
    EXPECT_TRUE(d.chunks.empty());
}

TEST(CaptureReader, TimestampsAreExactNanoseconds) {
    Drained d = read_all(capture("1763798400.022360 01\n"
                                 "0.5 02\n"
                                 "12.123456789 03\n"
                                 "7 04\n"
                                 "0.000000001 05\n"
                                 "-0.25 06\n"
                                 "9223372036.854775807 07\n"
                                 "1763798400.1 08\n"),
                         InputFormat::capture);
    ASSERT_FALSE(d.error) << d.error->to_string();
    ASSERT_EQ(d.chunks.size(), 8U);
    EXPECT_EQ(d.chunks[0].time, 1763798400022360000);
    EXPECT_EQ(d.chunks[1].time, 500000000);
    EXPECT_EQ(d.chunks[2].time, 12123456789);
    EXPECT_EQ(d.chunks[3].time, 7000000000);
    EXPECT_EQ(d.chunks[4].time, 1);
    EXPECT_EQ(d.chunks[5].time, -250000000);
    EXPECT_EQ(d.chunks[6].time, std::numeric_limits<Nanos>::max());
    EXPECT_EQ(d.chunks[7].time, 1763798400100000000);
}

TEST(CaptureReader, TimeGoingBackwardsIsKept) {
    Drained d = read_all(capture("2.0 01\n1.5 02\n"), InputFormat::capture);
    ASSERT_FALSE(d.error);
    ASSERT_EQ(d.chunks.size(), 2U);
    EXPECT_EQ(d.chunks[0].time, 2000000000);
    EXPECT_EQ(d.chunks[1].time, 1500000000);
}

TEST(CaptureReader, ChannelTags) {
    Drained d = read_all(capture("1.000 @A 01 03\n"
                                 "1.001\t@port2\t02\n"
                                 "1.002 03\n"),
                         InputFormat::capture);
    ASSERT_FALSE(d.error) << d.error->to_string();
    ASSERT_EQ(d.chunks.size(), 3U);
    EXPECT_EQ(d.chunks[0].channel, "A");
    EXPECT_EQ(d.chunks[0].bytes, (Bytes{0x01, 0x03}));
    EXPECT_EQ(d.chunks[1].channel, "port2");
    EXPECT_EQ(d.chunks[1].bytes, (Bytes{0x02}));
    EXPECT_EQ(d.chunks[2].channel, "");
}

TEST(CaptureReader, MixedCaseHexAndLooseWhitespace) {
    Drained d = read_all(capture("  3.25   0a Bc\tfF  9D   \n"), InputFormat::capture);
    ASSERT_FALSE(d.error) << d.error->to_string();
    ASSERT_EQ(d.chunks.size(), 1U);
    EXPECT_EQ(d.chunks[0].time, 3250000000);
    EXPECT_EQ(d.chunks[0].bytes, (Bytes{0x0A, 0xBC, 0xFF, 0x9D}));

    // Wider separators after a run of single spaces, and a bad byte after such a run.
    d = read_all(capture("4.5 01 02 03  04 05\t\t06 07 \n"), InputFormat::capture);
    ASSERT_FALSE(d.error) << d.error->to_string();
    ASSERT_EQ(d.chunks.size(), 1U);
    EXPECT_EQ(d.chunks[0].bytes, (Bytes{0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x07}));
    EXPECT_EQ(error_text(capture("4.5 01 02 03  0x 05\n")), "cap.rtucap:2:15: bad hex byte \"0x\"");
}

TEST(CaptureReader, ToleratesCrlfAndBomAndNoFinalNewline) {
    Drained d = read_all(
        "\xEF\xBB\xBF# rtuscope capture v1\r\n# serial 9600 8N1\r\n"
        "\r\n1.5 01 02\r\n2.5 03",
        InputFormat::capture);
    ASSERT_FALSE(d.error) << d.error->to_string();
    ASSERT_EQ(d.chunks.size(), 2U);
    EXPECT_EQ(d.chunks[0].bytes, (Bytes{0x01, 0x02}));
    EXPECT_EQ(d.chunks[0].source_line, 4);
    EXPECT_EQ(d.chunks[1].bytes, (Bytes{0x03}));
    EXPECT_EQ(d.chunks[1].time, 2500000000);
}

TEST(CaptureReader, SerialLineAfterDataUpdatesInfo) {
    auto source =
        from_memory(capture("1.0 01\n# serial 115200 8N2\n2.0 02\n"), InputFormat::capture);
    ASSERT_TRUE(source);
    EXPECT_FALSE(source->info().line.has_value());
    Drained d = drain(*source);
    ASSERT_FALSE(d.error);
    EXPECT_EQ(d.chunks.size(), 2U);
    ASSERT_TRUE(source->info().line.has_value());
    EXPECT_EQ(source->info().line->baud, 115200U);
    EXPECT_EQ(source->info().line->stop_bits, 2);
}

TEST(CaptureReader, HeaderErrors) {
    EXPECT_EQ(error_text("hello\n1.0 01\n"),
              "cap.rtucap:1:1: not an rtuscope capture (line 1 must be \"# rtuscope capture "
              "v1\")");
    EXPECT_EQ(error_text(""),
              "cap.rtucap:1:1: not an rtuscope capture (line 1 must be \"# rtuscope capture "
              "v1\")");
    EXPECT_EQ(error_text("1.0 01 02\n"),
              "cap.rtucap:1:1: not an rtuscope capture (line 1 must be \"# rtuscope capture "
              "v1\")");
    EXPECT_EQ(error_text("# rtuscope capture v2\n"),
              "cap.rtucap:1:1: unsupported capture version \"v2\" (this rtuscope reads v1)");
}

TEST(CaptureReader, SerialLineErrorsPointAtTheBadToken) {
    EXPECT_EQ(error_text(capture("# serial 96x0 8N1\n")),
              "cap.rtucap:2:10: bad baud rate \"96x0\" (expected a number from 50 to 4000000)");
    EXPECT_EQ(error_text(capture("# serial 9600 8X1\n")),
              "cap.rtucap:2:15: bad line format \"8X1\" (expected data bits 5-8, parity N/E/O, "
              "stop bits 1-2, e.g. 8N1 or 8E1)");
    EXPECT_EQ(error_text(capture("# serial\n")),
              "cap.rtucap:2:9: \"# serial\" needs a baud rate and a line format, e.g. "
              "\"# serial 9600 8N1\"");
    EXPECT_EQ(error_text(capture("# serial 9600\n")),
              "cap.rtucap:2:14: \"# serial\" needs a baud rate and a line format, e.g. "
              "\"# serial 9600 8N1\"");
    EXPECT_EQ(error_text(capture("# serial 9600 8N1 fast\n")),
              "cap.rtucap:2:19: unexpected \"fast\" after the line format");
    // Found while reading on, after a data line.
    EXPECT_EQ(error_text(capture("1.0 01\n# serial 0 8N1\n")),
              "cap.rtucap:3:10: bad baud rate \"0\" (expected a number from 50 to 4000000)");
    // Only the word "serial" makes a comment a settings line.
    EXPECT_EQ(error_text(capture("# serials are great\n1.0 01\n")), "(no error)");
}

TEST(CaptureReader, DataLineErrorsPointAtTheBadToken) {
    EXPECT_EQ(error_text(capture("1763798400.022360 01 03 0G\n")),
              "cap.rtucap:2:25: bad hex byte \"0G\"");
    EXPECT_EQ(error_text(capture("1.0 01 123 04\n")), "cap.rtucap:2:8: bad hex byte \"123\"");
    EXPECT_EQ(error_text(capture("1.0 01 3\n")), "cap.rtucap:2:8: bad hex byte \"3\"");
    EXPECT_EQ(error_text(capture("1.0 @A 01 @B\n")), "cap.rtucap:2:11: bad hex byte \"@B\"");
    EXPECT_EQ(error_text(capture("abc 01\n")),
              "cap.rtucap:2:1: bad timestamp \"abc\" (expected seconds, e.g. "
              "1763798400.022360)");
    EXPECT_EQ(error_text(capture("  1.2.3 01\n")),
              "cap.rtucap:2:3: bad timestamp \"1.2.3\" (expected seconds, e.g. "
              "1763798400.022360)");
    EXPECT_EQ(error_text(capture("1. 01\n")),
              "cap.rtucap:2:1: bad timestamp \"1.\" (expected seconds, e.g. "
              "1763798400.022360)");
    EXPECT_EQ(error_text(capture("1.0123456789 01\n")),
              "cap.rtucap:2:1: timestamp \"1.0123456789\" has more than 9 fractional digits");
    EXPECT_EQ(error_text(capture("9223372036.854775808 01\n")),
              "cap.rtucap:2:1: timestamp \"9223372036.854775808\" out of range");
    EXPECT_EQ(error_text(capture("1.0\n")), "cap.rtucap:2:4: no bytes after the timestamp");
    EXPECT_EQ(error_text(capture("1.0 @A  \n")), "cap.rtucap:2:7: no bytes after the timestamp");
    EXPECT_EQ(error_text(capture("1.0 @ 01\n")), "cap.rtucap:2:5: empty channel tag \"@\"");
    EXPECT_EQ(error_text(capture("1.0 @" + std::string(65, 'c') + " 01\n")),
              "cap.rtucap:2:5: channel tag \"@" + std::string(39, 'c') +
                  "...\" longer than 64 characters");
    EXPECT_EQ(read_all(capture("1.0 @" + std::string(64, 'c') + " 01\n"), InputFormat::capture)
                  .chunks.at(0)
                  .channel,
              std::string(64, 'c'));
    // Non-printable bytes are escaped so the message stays one readable line.
    EXPECT_EQ(error_text(capture("1.0 0\x01\n")), "cap.rtucap:2:5: bad hex byte \"0\\x01\"");
}

// Long lines are read eight bytes at a time, then one by one, the second loop taking over
// at every length and at the first character the first does not take: every length must
// give its bytes, and a bad character anywhere the error a byte at a time gives.
TEST(CaptureReader, EveryLineLengthAndEveryBadCharacterPlace) {
    auto expect_bytes = [](const std::string& line, const Bytes& bytes, const std::string& how) {
        Drained d = read_all(capture("1.5 " + line), InputFormat::capture);
        ASSERT_FALSE(d.error) << d.error->to_string();
        ASSERT_EQ(d.chunks.size(), 1U);
        EXPECT_EQ(d.chunks[0].bytes, bytes) << bytes.size() << " bytes, " << how;
    };
    std::mt19937 random(7);
    for (std::size_t n = 1; n <= 70; ++n) {
        Bytes bytes(n);
        std::string hex;
        for (std::size_t k = 0; k < n; ++k) {
            bytes[k] = static_cast<std::uint8_t>(random());
            hex += k % 2 == 0 ? fmt::format("{:02X}", bytes[k]) : fmt::format("{:02x}", bytes[k]);
            if (k + 1 < n) hex += ' ';
        }
        for (const char* ending : {"\n", " \n", "\r\n"}) {
            expect_bytes(hex + ending, bytes, "as written");
        }
        for (std::size_t at = 0; at < hex.size(); ++at) {
            if (at % 3 == 2) {  // a separator
                std::string tabbed = hex;
                tabbed[at] = '\t';
                expect_bytes(tabbed + "\n", bytes, fmt::format("tab at {}", at));
            }
            for (const char bad : {'G', 'g', '/', ':', '@', '`', 'x', '\x80', '\xC1'}) {
                if (at == 0 && bad == '@') continue;  // a channel tag ("@B 01 ...")
                std::string broken = hex;
                broken[at] = bad;
                // The token of the byte the character belongs to (the byte before a
                // separator), at its column: "1.5 " is four.
                const std::size_t column = 4 + at - at % 3 + 1;
                const std::string error = error_text(capture("1.5 " + broken + "\n"));
                EXPECT_TRUE(
                    error.starts_with(fmt::format("cap.rtucap:2:{}: bad hex byte \"", column)))
                    << n << " bytes, " << int{bad} << " at " << at << ": " << error;
            }
        }
    }
}

TEST(CaptureReader, ChunksBeforeAnErrorAreDeliveredAndTheErrorSticks) {
    auto source = from_memory(capture("# serial 9600 8N1\n"
                                      "1.0 01 03\n"
                                      "1.1 02\n"
                                      "\n"
                                      "# note\n"
                                      "1.2 03\n"
                                      "1.3 01 0G\n"
                                      "1.4 04\n"),
                              InputFormat::capture);
    ASSERT_TRUE(source);
    Drained d = drain(*source);
    ASSERT_EQ(d.chunks.size(), 3U);
    EXPECT_EQ(d.chunks[2].bytes, (Bytes{0x03}));
    EXPECT_EQ(d.chunks[2].source_line, 7);
    ASSERT_TRUE(d.error);
    EXPECT_EQ(d.error->file, "cap.rtucap");
    EXPECT_EQ(d.error->line, 8);
    EXPECT_EQ(d.error->column, 8);
    EXPECT_EQ(d.error->message, "bad hex byte \"0G\"");
    Chunk chunk;
    Result<bool> again = source->next(chunk);
    ASSERT_FALSE(again.ok());
    EXPECT_EQ(again.error().line, 8);
}

TEST(CaptureReader, ErrorOnTheFirstDataLineComesFromNext) {
    auto source =
        source_from_memory(capture("# serial 9600 8N1\nxyz 01\n"), "c", InputFormat::capture);
    ASSERT_TRUE(source.ok());
    Drained d = drain(**source);
    EXPECT_TRUE(d.chunks.empty());
    ASSERT_TRUE(d.error);
    EXPECT_EQ(d.error->line, 3);
    EXPECT_EQ(d.error->column, 1);
}

// --- raw ----------------------------------------------------------------------------------

TEST(RawReader, DeliversChunksOfAtMost4096BytesWithoutTime) {
    std::string content(10000, '\0');
    for (std::size_t i = 0; i < content.size(); ++i) content[i] = static_cast<char>(i * 7);
    auto source = from_memory(content, InputFormat::raw, "dump.bin");
    ASSERT_TRUE(source);
    EXPECT_EQ(source->info().format, "raw");
    EXPECT_EQ(source->info().name, "dump.bin");
    EXPECT_FALSE(source->info().timed);
    EXPECT_EQ(source->info().time_base, TimeBase::none);
    EXPECT_FALSE(source->info().chunk_is_line);
    EXPECT_FALSE(source->info().line.has_value());
    Drained d = drain(*source);
    ASSERT_FALSE(d.error);
    ASSERT_EQ(d.chunks.size(), 3U);
    EXPECT_EQ(d.chunks[0].bytes.size(), 4096U);
    EXPECT_EQ(d.chunks[1].bytes.size(), 4096U);
    EXPECT_EQ(d.chunks[2].bytes.size(), 1808U);
    for (const Chunk& c : d.chunks) {
        EXPECT_EQ(c.time, kNoTime);
        EXPECT_EQ(c.source_line, 0);
        EXPECT_EQ(c.channel, "");
    }
    EXPECT_EQ(d.chunks[1].bytes[0], static_cast<std::uint8_t>(4096 * 7));
    EXPECT_EQ(d.chunks[2].bytes.back(), static_cast<std::uint8_t>(9999 * 7));
}

TEST(RawReader, EmptyInputHasNoChunks) {
    auto source = from_memory("", InputFormat::automatic, "empty.bin");
    ASSERT_TRUE(source);
    EXPECT_EQ(source->info().format, "raw");
    Drained d = drain(*source);
    EXPECT_FALSE(d.error);
    EXPECT_TRUE(d.chunks.empty());
}

// --- hex logs -------------------------------------------------------------------------------

struct HexCase {
    const char* line;
    Bytes bytes;
    Nanos time;
    const char* channel;  // from the line's direction word, "" if none
};

// Reads each line as a log of its own, which must give one chunk of `bytes` at `time` on
// `channel`; a line of more than 3 bytes is one frame with its right CRC.
void expect_each_line_read(const std::vector<HexCase>& cases) {
    for (const HexCase& c : cases) {
        SCOPED_TRACE(c.line);
        auto source = from_memory(std::string(c.line) + "\n", InputFormat::hex, "log.txt");
        ASSERT_TRUE(source);
        EXPECT_EQ(source->info().format, "hex");
        EXPECT_TRUE(source->info().chunk_time_is_start);
        EXPECT_EQ(source->info().timed, has_time(c.time));
        Drained d = drain(*source);
        ASSERT_FALSE(d.error);
        ASSERT_EQ(d.chunks.size(), 1U);
        EXPECT_EQ(d.chunks[0].bytes, c.bytes);
        EXPECT_EQ(d.chunks[0].time, c.time);
        EXPECT_EQ(d.chunks[0].source_line, 1);
        EXPECT_EQ(d.chunks[0].channel, c.channel);
        // The 3-byte lines are no frame, and go to the framer (and into the closing note).
        const bool whole = c.bytes.size() > 3;
        EXPECT_EQ(d.chunks[0].whole_frame, whole);
        EXPECT_EQ(
            source->remarks(),
            whole ? std::vector<std::string>{}
                  : std::vector<std::string>{"no line held one frame, 1 line was framed as a byte "
                                             "stream (not one frame by length and CRC)"});
    }
}

TEST(HexReader, ReadsManualAndTerminalLines) {
    expect_each_line_read({
        {"主机：01 03 00 00 00 02 c4 0b",
         {0x01, 0x03, 0x00, 0x00, 0x00, 0x02, 0xC4, 0x0B},
         kNoTime,
         "master"},
        {"ZB-UVI485模块：**01 03 02 18 18 b2 4e**",
         {0x01, 0x03, 0x02, 0x18, 0x18, 0xB2, 0x4E},
         kNoTime,
         ""},
        {"串口调试助手： 01 04 00 15 00 12 61 c3",
         {0x01, 0x04, 0x00, 0x15, 0x00, 0x12, 0x61, 0xC3},
         kNoTime,
         ""},
        {"[2024-05-01 10:21:33.120] TX: 01 03 00 00 00 02 C4 0B",
         {0x01, 0x03, 0x00, 0x00, 0x00, 0x02, 0xC4, 0x0B},
         1714558893120000000,
         "master"},
        {"10:21:33.120 RX 01 03 02 17 F8 B6 36",
         {0x01, 0x03, 0x02, 0x17, 0xF8, 0xB6, 0x36},
         37293120000000,
         "slave"},
        {"010300000002C40B", {0x01, 0x03, 0x00, 0x00, 0x00, 0x02, 0xC4, 0x0B}, kNoTime, ""},
        {"TX:01 06 00 01 00 03 98 0B",
         {0x01, 0x06, 0x00, 0x01, 0x00, 0x03, 0x98, 0x0B},
         kNoTime,
         "master"},
        {"RX>01 06 00 01 00 03 98 0B",
         {0x01, 0x06, 0x00, 0x01, 0x00, 0x03, 0x98, 0x0B},
         kNoTime,
         "slave"},
        {"send: 010300000002C40B",
         {0x01, 0x03, 0x00, 0x00, 0x00, 0x02, 0xC4, 0x0B},
         kNoTime,
         "master"},
        {"RECV:0103021818B24E", {0x01, 0x03, 0x02, 0x18, 0x18, 0xB2, 0x4E}, kNoTime, "slave"},
        {"发送 -> 01 03 00 00 00 02 C4 0B",
         {0x01, 0x03, 0x00, 0x00, 0x00, 0x02, 0xC4, 0x0B},
         kNoTime,
         "master"},
        {"{0x01, 0x03, 0x00, 0x00, 0x00, 0x02, 0xC4, 0x0B}",
         {0x01, 0x03, 0x00, 0x00, 0x00, 0x02, 0xC4, 0x0B},
         kNoTime,
         ""},
        {"0x01, 0x03, 0x00, 0x00, 0x00, 0x02, 0xC4, 0x0B,",
         {0x01, 0x03, 0x00, 0x00, 0x00, 0x02, 0xC4, 0x0B},
         kNoTime,
         ""},
        {"`01 03 02 17 F8 B6 36`", {0x01, 0x03, 0x02, 0x17, 0xF8, 0xB6, 0x36}, kNoTime, ""},
        {"[10:21:33.120]收←◆01 03 02 17 F8 B6 36",  // sscom
         {0x01, 0x03, 0x02, 0x17, 0xF8, 0xB6, 0x36},
         37293120000000,
         "slave"},
        {"2024-05-01T10:21:33Z 01 03 00", {0x01, 0x03, 0x00}, 1714558893000000000, ""},
        {"2024-05-01 18:21:33+08:00 01 03 00", {0x01, 0x03, 0x00}, 1714558893000000000, ""},
        {"2024/05/01 10:21:33,5 01 03 00", {0x01, 0x03, 0x00}, 1714558893500000000, ""},
        {"9:05:03 01 03 00", {0x01, 0x03, 0x00}, 32703000000000, ""},
        {"10:21:33 AB CD EF", {0xAB, 0xCD, 0xEF}, 37293000000000, ""},
        {"01 03 00 00 00 02 C4 0B # read 2 registers 01 02 03",
         {0x01, 0x03, 0x00, 0x00, 0x00, 0x02, 0xC4, 0x0B},
         kNoTime,
         ""},
        {"Frame #3: 01 03 02 17 F8 B6 36 // answer",
         {0x01, 0x03, 0x02, 0x17, 0xF8, 0xB6, 0x36},
         kNoTime,
         ""},
        {"| 01 03 02 17 F8 B6 36 |", {0x01, 0x03, 0x02, 0x17, 0xF8, 0xB6, 0x36}, kNoTime, ""},
        {"主机，01，03，00", {0x01, 0x03, 0x00}, kNoTime, "master"},
        {"发送：01H 03H 00H 00H 00H 01H 84H 0AH",
         {0x01, 0x03, 0x00, 0x00, 0x00, 0x01, 0x84, 0x0A},
         kNoTime,
         "master"},
    });
}

// The line styles of other tools' logs, each as its tool writes a request (or an answer):
// the bytes in one style, whatever the decoration, counts and columns around them.
TEST(HexReader, ReadsTheLineStylesOfOtherTools) {
    const Bytes request = {0x06, 0x03, 0x00, 0x00, 0x00, 0x02, 0xC5, 0xBC};
    const Bytes answer = {0x06, 0x03, 0x04, 0x00, 0xE6, 0x00, 0x00, 0x6D, 0x04};
    const Nanos esphome_time = ((20 * 60 + 22) * 60 + 2) * kNanosPerSecond;
    expect_each_line_read({
        {"06 03 00 00 00 02 C5 BC", request, kNoTime, ""},
        {"06-03-00-00-00-02-C5-BC", request, kNoTime, ""},
        {"06:03:00:00:00:02:C5:BC", request, kNoTime, ""},
        {"06.03.00.00.00.02.C5.BC", request, kNoTime, ""},
        {"060300000002C5BC", request, kNoTime, ""},
        // libmodbus's debug output: [..] is what it sent, <..> what it received.
        {"[06][03][00][00][00][02][C5][BC]", request, kNoTime, "master"},
        {"<06><03><04><00><E6><00><00><6D><04>", answer, kNoTime, "slave"},
        {"0x06 0x03 0x00 0x00 0x00 0x02 0xC5 0xBC", request, kNoTime, ""},
        {"0x6 0x3 0x0 0x0 0x0 0x2 0xc5 0xbc", request, kNoTime, ""},
        {"06 03 00 00 00 02 C5 BC (8 bytes)", request, kNoTime, ""},
        {"06 03 00 00 00 02 C5 BC (8)", request, kNoTime, ""},
        {"<Buffer 06 03 00 00 00 02 c5 bc>", request, kNoTime, ""},
        {"Tx: 06 03 00 00 00 02 C5 BC", request, kNoTime, "master"},
        {"Rx: 06 03 04 00 E6 00 00 6D 04", answer, kNoTime, "slave"},
        {">>> 06 03 00 00 00 02 C5 BC", request, kNoTime, "master"},
        {"<<< 06 03 04 00 E6 00 00 6D 04", answer, kNoTime, "slave"},
        {"Tx:06:03:00:00:00:02:C5:BC", request, kNoTime, "master"},
        {"[20:22:02][D][uart_debug:114]: >>> 06:03:00:00:00:02:C5:BC", request, esphome_time,
         "master"},
        // ESPHome's logger colours its lines.
        {"[20:22:02]\x1B[0;36m[D][uart_debug:114]: <<< 06:03:04:00:E6:00:00:6D:04\x1B[0m", answer,
         esphome_time, "slave"},
        {"| 0000: 06 03 00 00 00 02 C5 BC                         |........|", request, kNoTime,
         ""},
        {"00000000  06 03 00 00 00 02 c5 bc                           |........|", request, kNoTime,
         ""},
        {"0000: 06 03 00 00 00 02 c5 bc  ........", request, kNoTime, ""},
        // The ASCII column shows printable bytes as themselves: "0123" and "AB" are not bytes.
        {"| 0000: 11 03 06 41 42 30 31 32 33 90 11                |...AB0123..|",
         {0x11, 0x03, 0x06, 0x41, 0x42, 0x30, 0x31, 0x32, 0x33, 0x90, 0x11},
         kNoTime,
         ""},
        {"Modbus write: 06.03.00.00.00.02.C5.BC (8) at 305852", request, kNoTime, "master"},
        {"Modbus read: 06.03.04.00.E6.00.00.6D.04 (9) at 305871", answer, kNoTime, "slave"},
        {"2024-05-01T08:21:33.120Z TX <Buffer 06 03 00 00 00 02 c5 bc>", request,
         1714551693120000000, "master"},
        {"2024-05-01 10:21:33,120 DEBUG rs485: send: 0x6 0x3 0x0 0x0 0x0 0x2 0xc5 0xbc", request,
         1714558893120000000, "master"},
        {"16:54:34:233 Tx: 06-03-00-00-00-02-C5-BC", request,
         ((16 * 60 + 54) * 60 + 34) * kNanosPerSecond + 233000000, "master"},
        {"10.05.2024 14:02:11.250 RX: 06 03 04 00 E6 00 00 6D 04", answer, 1715349731250000000,
         "slave"},
        {"Writing to instrument (expecting 9 bytes back): (06 03 00 00 00 02 C5 BC) (8 bytes)",
         request, kNoTime, "master"},
        {"Response: 06 03 04 00 E6 00 00 6D 04", answer, kNoTime, "slave"},
        {"Master -> Slave: 06 03 00 00 00 02 C5 BC", request, kNoTime, "master"},
    });
}

// Numbers that look like hex (a count, a millisecond counter, a baud rate, a 16-bit value,
// a decimal, a MAC address beside a frame) never become bytes, and never beat the frame
// on the line.
TEST(HexReader, NeverInventsBytesFromNumbers) {
    auto source = from_memory(
        "Opening /dev/ttyUSB0 at 9600 bauds (N, 8, 1)\n"                       // 1
        "Modbus timeout at 307852\n"                                           // 2
        "ERROR CRC received 0xCA08 != CRC calculated 0xCA09\n"                 // 3
        "Temperature 12.34 C, step 12-14\n"                                    // 4
        "Modbus read: 06.03.02.00.32.8C.51 (7) at 308870\n"                    // 5
        "Modbus write: 06.03.02 (3) at 305852\n"                               // 6
        "TX 06 03 00 00 00 02 C5 BC, 16 bytes in the buffer, 12 more bytes\n"  // 7
        "len=20 RX 06 03 04 00 E6 00 00 6D 04\n"                               // 8
        "Uptime 12345678 ms, free heap 21344\n"                               // 9
        "Serial number 20240501\n"                                            // 10
        "Decimal digits, one frame: 0103000000044409\n",                      // 11
        InputFormat::hex, "log.txt");
    ASSERT_TRUE(source);
    Drained d = drain(*source);
    ASSERT_FALSE(d.error);
    ASSERT_EQ(d.chunks.size(), 5U);
    EXPECT_EQ(d.chunks[0].bytes, (Bytes{0x06, 0x03, 0x02, 0x00, 0x32, 0x8C, 0x51}));
    EXPECT_EQ(d.chunks[1].bytes, (Bytes{0x06, 0x03, 0x02}));
    EXPECT_EQ(d.chunks[2].bytes, (Bytes{0x06, 0x03, 0x00, 0x00, 0x00, 0x02, 0xC5, 0xBC}));
    EXPECT_EQ(d.chunks[3].bytes, (Bytes{0x06, 0x03, 0x04, 0x00, 0xE6, 0x00, 0x00, 0x6D, 0x04}));
    EXPECT_EQ(d.chunks[4].bytes, (Bytes{0x01, 0x03, 0x00, 0x00, 0x00, 0x04, 0x44, 0x09}));
    EXPECT_EQ(source->remarks().back(), "skipped 6 lines with no frame: 1-4, 9-10");
}

TEST(HexReader, NeverReadsATimestampAsBytes) {
    // "10:21:33" must not become 10 21 33: the lines hold two, two and three bytes.
    Drained d = read_all(
        "10:21:33 01 02\n"
        "10:21:33:01 03 04\n"
        "2024-05-01 10:21:33 01 03 04\n",
        InputFormat::hex);
    ASSERT_FALSE(d.error);
    ASSERT_EQ(d.chunks.size(), 3U);
    EXPECT_EQ(d.chunks[0].bytes, (Bytes{0x01, 0x02}));
    EXPECT_EQ(d.chunks[1].bytes, (Bytes{0x03, 0x04}));
    EXPECT_EQ(d.chunks[2].bytes, (Bytes{0x01, 0x03, 0x04}));
    EXPECT_EQ(d.chunks[2].source_line, 3);
}

// A terminal that logs each read() splits frames over lines, and may put several on one:
// a line that is one frame (by length and CRC) is taken whole, any other goes to the
// framer, and the closing note counts both. A line of one or two bytes is one read()
// when it has a timestamp; without one it is skipped as before (a manual's "step 2").
TEST(HexReader, MarksTheLinesThatAreOneFrameAndCountsBoth) {
    auto source = from_memory(
        "[10:00:00.000] TX: 01 03 00 00 00 02 C4 0B\n"          // one frame
        "[10:00:00.020] RX: 01 03 04 08\n"                      // a piece
        "[10:00:00.021] RX: 9D\n"                               // one byte, timed
        "[10:00:00.022] RX: 00 96 E9 D3\n"                      // a piece
        "01 03 00 00 00 02 C4 0B 01 03 04 08 9D 00 96 E9 D3\n"  // two frames
        "01 03 04 08 9D 00 96 E9 D4\n"                          // a wrong CRC
        "01 02\n"                                               // skipped
        "01 08 00 00 12 34 ED 7C\n"                             // FC08/00, CRC
        "[10:00:01.000] 01 03 00 00 00 02 C4 0B\n",             // one frame
        InputFormat::hex, "log.txt");
    ASSERT_TRUE(source);
    EXPECT_TRUE(source->info().chunk_time_is_start);
    EXPECT_TRUE(source->info().chunk_is_line);
    Drained d = drain(*source);
    ASSERT_FALSE(d.error);
    std::vector<bool> whole;
    std::vector<int> lines;
    for (const Chunk& c : d.chunks) {
        whole.push_back(c.whole_frame);
        lines.push_back(c.source_line);
    }
    EXPECT_EQ(whole, (std::vector<bool>{true, false, false, false, false, false, true, true}));
    EXPECT_EQ(lines, (std::vector<int>{1, 2, 3, 4, 5, 6, 8, 9}));
    EXPECT_EQ(d.chunks[2].bytes, (Bytes{0x9D}));
    EXPECT_EQ(d.chunks[2].time, 36000021000000);
    EXPECT_EQ(source->remarks(),
              (std::vector<std::string>{"3 lines held one frame each, 5 lines were framed as a "
                                        "byte stream (not one frame by length and CRC)",
                                        "skipped 1 line with no frame: 7"}));
}

TEST(HexReader, SkippedLinesAreSummarisedInOneRemark) {
    auto source = from_memory(
        "Modbus example\n"  // 1 skipped
        "request:\n"        // a label: its direction goes to the lines under it
        "01 03\n"           // 3 skipped: too short
        "01 03 00 00 00 02 C4 0B\n"
        "\n"                    // blank: not counted
        "# comment 01 02 03\n"  // comment: not counted
        "answer follows\n"      // 7 skipped: prose, no label
        "01 03 02 17 F8 B6 36\n"
        "done.\n"  // 9 skipped
        "   // another comment\n",
        InputFormat::hex, "manual.txt");
    ASSERT_TRUE(source);
    Drained d = drain(*source);
    ASSERT_FALSE(d.error);
    ASSERT_EQ(d.chunks.size(), 2U);
    EXPECT_EQ(d.chunks[0].source_line, 4);
    EXPECT_EQ(d.chunks[0].channel, "master");
    EXPECT_EQ(d.chunks[1].source_line, 8);
    EXPECT_EQ(d.chunks[1].channel, "");
    EXPECT_FALSE(source->info().timed);
    EXPECT_EQ(source->remarks(),
              std::vector<std::string>{"skipped 4 lines with no frame: 1, 3, 7, 9"});
}

TEST(HexReader, TimedWhenAnyLineHasATimeAndTimeOfDayRollsOverMidnight) {
    auto source = from_memory(
        "23:59:59.900 TX 01 03 00 00 00 01 84 0A\r\n"
        "00:00:00.100 RX 01 03 02 00 2A 39 9B\r\n",
        InputFormat::hex);
    ASSERT_TRUE(source);
    EXPECT_TRUE(source->info().timed);
    Drained d = drain(*source);
    ASSERT_EQ(d.chunks.size(), 2U);
    EXPECT_EQ(d.chunks[0].time, 86399900000000);
    EXPECT_EQ(d.chunks[1].time, 86400100000000);
    EXPECT_EQ(d.chunks[1].bytes.back(), 0x9B);  // CR stripped
}

// What a log's times are, from its first timestamp: a date with a UTC offset is Unix
// time, a date without one is read as printed (counted as if UTC), a time of day alone is
// a time of day; no timestamp, no times.
TEST(HexReader, SaysWhatItsTimesAre) {
    const std::vector<std::pair<const char*, TimeBase>> cases = {
        {"2024-05-01T10:21:33Z 01 03 00 00 00 02 C4 0B", TimeBase::unix_time},
        {"2024-05-01 18:21:33+08:00 01 03 00 00 00 02 C4 0B", TimeBase::unix_time},
        {"[2024-05-01 10:21:33.120] 01 03 00 00 00 02 C4 0B", TimeBase::wall_clock},
        {"2024-05-01 10:21:33 Zone 01 03 00 00 00 02 C4 0B", TimeBase::wall_clock},
        {"[10:21:33.120] 01 03 00 00 00 02 C4 0B", TimeBase::time_of_day},
        {"01 03 00 00 00 02 C4 0B", TimeBase::none},
    };
    for (const auto& [line, base] : cases) {
        SCOPED_TRACE(line);
        auto source = from_memory(std::string(line) + "\n", InputFormat::hex);
        ASSERT_TRUE(source);
        EXPECT_EQ(source->info().time_base, base);
    }
}

// Each timestamp style keeps its time, and says what its times are; a time of the header
// line above the bytes (asyn's, a hexdump's) counts as the line's own.
TEST(HexReader, KeepsTheTimeOfEachTimestampStyle) {
    struct TimeCase {
        const char* log;
        Nanos time;
        TimeBase base;
    };
    const Nanos day = 19844 * kNanosPerDay;  // 2024-05-01
    const Nanos tod = ((10 * 60 + 21) * 60 + 33) * kNanosPerSecond + 120'000'000;
    const std::vector<TimeCase> cases = {
        {"10:21:33.120 TX 01 03 00 00 00 02 C4 0B", tod, TimeBase::time_of_day},
        {"10:21:33,120 TX 01 03 00 00 00 02 C4 0B", tod, TimeBase::time_of_day},
        {"10:21:33:120 TX 01 03 00 00 00 02 C4 0B", tod, TimeBase::time_of_day},
        {"[10:21:33] TX 01 03 00 00 00 02 C4 0B", tod - 120'000'000, TimeBase::time_of_day},
        {"[10:21:33]\x1B[0;36m[D][uart_debug:114]: >>> 01:03:00:00:00:02:C4:0B\x1B[0m",
         tod - 120'000'000, TimeBase::time_of_day},
        {"2024-05-01 10:21:33.120 TX 01 03 00 00 00 02 C4 0B", day + tod, TimeBase::wall_clock},
        {"2024-05-01 10:21:33,120 DEBUG send: 0x1 0x3 0x0 0x0 0x0 0x2 0xc4 0xb", day + tod,
         TimeBase::wall_clock},
        {"01.05.2024 10:21:33.120 TX 01 03 00 00 00 02 C4 0B", day + tod, TimeBase::wall_clock},
        {"2024-05-01T10:21:33.120Z TX 01 03 00 00 00 02 C4 0B", day + tod, TimeBase::unix_time},
        {"2024-05-01T12:21:33.120+02:00 TX 01 03 00 00 00 02 C4 0B", day + tod,
         TimeBase::unix_time},
        {"2024/05/01 10:21:33.120 /dev/ttyS0 write 8\n\n01 03 00 00 00 02 c4 0b \n", day + tod,
         TimeBase::wall_clock},
        {"01.05.2024 10:21:33.120 TX (8 bytes)\n| 0000: 01 03 00 00 00 02 C4 0B  |........|",
         day + tod, TimeBase::wall_clock},
    };
    for (const TimeCase& c : cases) {
        SCOPED_TRACE(c.log);
        auto source = from_memory(std::string(c.log) + "\n", InputFormat::hex);
        ASSERT_TRUE(source);
        EXPECT_EQ(source->info().time_base, c.base);
        EXPECT_TRUE(source->info().timed);
        Drained d = drain(*source);
        ASSERT_EQ(d.chunks.size(), 1U);
        EXPECT_EQ(d.chunks[0].bytes, (Bytes{0x01, 0x03, 0x00, 0x00, 0x00, 0x02, 0xC4, 0x0B}));
        EXPECT_EQ(d.chunks[0].time, c.time);
        EXPECT_EQ(d.chunks[0].channel, "master");
        EXPECT_TRUE(source->remarks().empty());
    }
}

// What a log sent (TX, >>>, send, libmodbus's [..]) is the master's when the program that
// wrote it is the master, as most are; libmodbus says when it is a slave ("Waiting for an
// indication"), and a log whose sent frames are answers shows it by their shapes.
TEST(HexReader, DirectionsBecomeChannelsSeenFromTheProgramThatWroteTheLog) {
    const auto channels = [](const std::string& log) {
        auto source = from_memory(log, InputFormat::hex, "log.txt");
        std::vector<std::string> out;
        if (!source) return out;
        for (const Chunk& c : drain(*source).chunks) out.push_back(c.channel);
        return out;
    };
    using Channels = std::vector<std::string>;
    // A master's log: an FC06 write and its echo, the same bytes both ways.
    EXPECT_EQ(channels("TX: 01 06 00 01 00 03 98 0B\nRX: 01 06 00 01 00 03 98 0B\n"),
              (Channels{"master", "slave"}));
    EXPECT_EQ(channels("sent 01 06 00 01 00 03 98 0B\nreceived 01 06 00 01 00 03 98 0B\n"),
              (Channels{"master", "slave"}));
    EXPECT_EQ(channels(">>> 01 06 00 01 00 03 98 0B\n<<< 01 06 00 01 00 03 98 0B\n"),
              (Channels{"master", "slave"}));
    EXPECT_EQ(channels("[01][06][00][01][00][03][98][0B]\nWaiting for a confirmation...\n"
                       "<01><06><00><01><00><03><98><0B>\n"),
              (Channels{"master", "slave"}));
    // libmodbus as a slave: it receives the requests.
    EXPECT_EQ(channels("Waiting for an indication...\n<01><06><00><01><00><03><98><0B>\n"
                       "[01][06][00][01][00][03][98][0B]\n"),
              (Channels{"master", "slave"}));
    // A slave simulator's log: it receives reads and sends their answers.
    EXPECT_EQ(channels("RX: 01 03 00 00 00 02 C4 0B\nTX: 01 03 04 08 9D 00 96 E9 D3\n"
                       "RX: 01 06 00 01 00 03 98 0B\nTX: 01 06 00 01 00 03 98 0B\n"),
              (Channels{"master", "slave", "master", "slave"}));
    // Named outright, whatever wrote the log.
    EXPECT_EQ(channels("Request: 01 03 00 00 00 02 C4 0B\nResponse: 01 03 04 08 9D 00 96 E9 D3\n"),
              (Channels{"master", "slave"}));
    // A read() that returned the adapter's echo of the request and then the answer goes
    // both ways: no channel, and the framer tells them apart by shape.
    EXPECT_EQ(channels("TX: 01 03 00 00 00 02 C4 0B\n"
                       "RX: 01 03 00 00 00 02 C4 0B 01 03 04 08 9D 00 96 E9 D3\n"),
              (Channels{"master", ""}));
}

// asyn's traceIOHex prints a header (time, port, write/read and a count) and the bytes
// under it, 20 a line; a hexdump prints rows under a header. The lines of bytes take the
// header's time and direction, and the header is no skipped line.
TEST(HexReader, HeaderLinesGiveTheirTimeAndDirectionToTheBytesUnderThem) {
    auto source = from_memory(
        "2024/05/01 10:21:33.120 /dev/ttyS0 write 8\n"
        "\n"
        "03 03 00 00 00 14 44 27 \n"
        "2024/05/01 10:21:33.183 /dev/ttyS0 read 21\n"
        "\n"
        "03 03 28 01 10 01 11 01 12 01 13 01 14 01 15 01 16 01 17 01 \n"
        "18 \n"
        "a line of prose\n"
        "03 03 \n",
        InputFormat::hex, "asyn.log");
    ASSERT_TRUE(source);
    Drained d = drain(*source);
    ASSERT_FALSE(d.error);
    ASSERT_EQ(d.chunks.size(), 3U);
    const Nanos write_time = 1714558893120000000;
    const Nanos read_time = 1714558893183000000;
    EXPECT_EQ(d.chunks[0].time, write_time);
    EXPECT_EQ(d.chunks[0].channel, "master");
    EXPECT_TRUE(d.chunks[0].whole_frame);
    EXPECT_EQ(d.chunks[1].time, read_time);
    EXPECT_EQ(d.chunks[1].channel, "slave");
    EXPECT_EQ(d.chunks[1].bytes.size(), 20U);
    EXPECT_FALSE(d.chunks[1].whole_frame);
    // The wrapped frame's last line: one byte, the header's time and direction.
    EXPECT_EQ(d.chunks[2].bytes, (Bytes{0x18}));
    EXPECT_EQ(d.chunks[2].time, read_time);
    EXPECT_EQ(d.chunks[2].channel, "slave");
    EXPECT_EQ(d.chunks[2].source_line, 7);
    // Prose ends the header's reach: "03 03" is two bytes of nothing.
    EXPECT_EQ(source->remarks().back(), "skipped 2 lines with no frame: 8-9");
}

// A log that gives a direction with its frames (a firmware's log, a terminal's) also
// prints other things: an address, a MAC, a CRC it computed. Such a line, without a
// direction and not one whole frame, is skipped and listed.
TEST(HexReader, ALogThatGivesDirectionsSkipsBytesWithoutOne) {
    auto source = from_memory(
        "[20:21:58][C][wifi:577]:   Local MAC: 24:0A:C4:5F:21:30\n"
        "[20:22:02][D][uart_debug:114]: >>> 06:03:00:00:00:02:C5:BC\n"
        "[20:22:02][D][uart_debug:114]: <<< 06:03:04:00:E6\n"
        "[20:22:02][D][uart_debug:114]: <<< 00:00:6D:04\n"
        "[20:22:03][D][raw:010]: 06:03:00:00:00:02:C5:BC\n"
        "[20:22:12][D][uart_debug:114]: >>> 06:03:00:00:00:02:C5:BC\n"
        "[20:22:12][D][uart_debug:114]: <<< 06:03:04:00:E5:00:00:9D:05\n"
        "[20:22:12][W][modbus:108]: Modbus CRC Check failed! 059D!=049D\n",
        InputFormat::hex, "esphome.log");
    ASSERT_TRUE(source);
    Drained d = drain(*source);
    ASSERT_FALSE(d.error);
    std::vector<int> lines;
    for (const Chunk& c : d.chunks) lines.push_back(c.source_line);
    // Line 5 has no direction but is one whole frame: kept.
    EXPECT_EQ(lines, (std::vector<int>{2, 3, 4, 5, 6, 7}));
    EXPECT_EQ(source->remarks().back(),
              "skipped 2 lines with bytes but no direction, in a log that gives one with its "
              "frames: 1, 8");
}

// Lines made of the pieces of every line style (brackets, joiners, 0x, counts, offsets,
// ASCII columns, times, escapes, directions) in random order and cut anywhere: chunks or
// skipped lines, never a crash or an overrun (the sanitizer builds check the reads).
TEST(HexReader, LinesOfRandomLogPiecesNeverCrash) {
    const std::vector<std::string> pieces = {"01",
                                             "0B",
                                             "c5",
                                             "0x",
                                             "0x6",
                                             "0x06",
                                             "0x0103000000",
                                             "[",
                                             "]",
                                             "[01]",
                                             "<",
                                             ">",
                                             "<0B>",
                                             "-",
                                             ":",
                                             ".",
                                             "06:03",
                                             "06-03-",
                                             "06.03.00",
                                             "(",
                                             ")",
                                             "(8 bytes)",
                                             "8",
                                             "bytes",
                                             "more",
                                             "len=",
                                             "|",
                                             "|....|",
                                             "0000:",
                                             "00000000  ",
                                             "\x1B[0;36m",
                                             "\x1B[",
                                             "\x1B",
                                             "TX",
                                             "Rx:",
                                             ">>>",
                                             "<<<",
                                             "write",
                                             "read",
                                             "10:21:33",
                                             ".120",
                                             ",5",
                                             ":120",
                                             "2024-05-01",
                                             "T",
                                             "Z",
                                             "+08:00",
                                             "01.05.2024 ",
                                             "#",
                                             "//",
                                             "H",
                                             "主机",
                                             "：",
                                             "←",
                                             " ",
                                             " ",
                                             " ",
                                             "\t",
                                             "Waiting for an indication",
                                             "\xE6"};
    std::mt19937 random(2024);
    for (int round = 0; round < 400; ++round) {
        std::string text;
        for (int line = 0; line < 20; ++line) {
            const int n = static_cast<int>(random() % 12);
            for (int k = 0; k < n; ++k) text += pieces[random() % pieces.size()];
            text += '\n';
        }
        text.resize(random() % (text.size() + 1));
        auto source = source_from_memory(text, "random.log", InputFormat::hex);
        ASSERT_TRUE(source);
        Drained d = drain(**source);
        ASSERT_FALSE(d.error);
        for (const Chunk& c : d.chunks) {
            ASSERT_FALSE(c.bytes.empty());
            if (c.whole_frame) {
                ASSERT_GE(c.bytes.size(), kMinAdu);
            }
            ASSERT_TRUE(c.channel.empty() || c.channel == "master" || c.channel == "slave");
        }
        (void)(*source)->remarks();
    }
}

// Text that is no log (a README, a source file) read as one says so, beside the lines it
// skipped.
TEST(HexReader, SaysWhenTheTextIsNoLog) {
    std::string text = "# A project\n\nSome prose about 01 03 00 00 00 02 C4 0B.\n";
    for (int i = 0; i < 10; ++i) text += "More prose, line " + std::to_string(i) + ".\n";
    auto source = from_memory(text, InputFormat::hex, "README.md");
    ASSERT_TRUE(source);
    Drained d = drain(*source);
    ASSERT_EQ(d.chunks.size(), 1U);
    EXPECT_EQ(source->remarks(),
              (std::vector<std::string>{"only 1 of 11 lines held bytes in hex: this does not "
                                        "look like a hex log (10 lines skipped)"}));
    auto prose = from_memory("hello world\n", InputFormat::hex, "hello.txt");
    ASSERT_TRUE(prose);
    drain(*prose);
    EXPECT_EQ(prose->remarks(),
              (std::vector<std::string>{
                  "no line held bytes in hex: this is not a hex log (1 line skipped)"}));
}

TEST(HexReader, EmptyAndCommentOnlyLogsHaveNoRemark) {
    auto source = from_memory("# nothing\n\n", InputFormat::hex);
    ASSERT_TRUE(source);
    Drained d = drain(*source);
    EXPECT_TRUE(d.chunks.empty());
    EXPECT_TRUE(source->remarks().empty());
}

// --- detection ------------------------------------------------------------------------------

TEST(SourcesDetect, RecognisesEachFormat) {
    EXPECT_EQ(detect_input_format("# rtuscope capture v1\n1.0 01\n"), InputFormat::capture);
    EXPECT_EQ(detect_input_format("\xEF\xBB\xBF# rtuscope capture v1\n"), InputFormat::capture);
    // A capture of an unknown version is still a capture; the reader says what is wrong.
    EXPECT_EQ(detect_input_format("# rtuscope capture v2\n"), InputFormat::capture);
    EXPECT_EQ(detect_input_format("TX: 01 03 00 00 00 02 C4 0B\n"), InputFormat::hex);
    EXPECT_EQ(detect_input_format("Example\n\n主机：01 03 00 00 00 02 c4 0b\n"), InputFormat::hex);
    EXPECT_EQ(detect_input_format("010300000002C40B"), InputFormat::hex);
    EXPECT_EQ(detect_input_format(std::string("\x01\x03\x00\x00\x00\x02\xC4\x0B", 8)),
              InputFormat::raw);
    EXPECT_EQ(detect_input_format("01 03 00 00\x1B\x03\n"), InputFormat::raw);   // control bytes
    EXPECT_EQ(detect_input_format("01 03 00 00\x1B(B\n"), InputFormat::raw);     // not a colour
    EXPECT_EQ(detect_input_format("caf\xE9: 01 03 00 00\n"), InputFormat::raw);  // Latin-1
    // Text with no frame in its head is still a log: the hex reader then lists the lines
    // it skipped instead of decoding prose as bus noise.
    EXPECT_EQ(detect_input_format("hello world\n"), InputFormat::hex);
    EXPECT_EQ(detect_input_format("10:21:33 01 02\n"), InputFormat::hex);
    EXPECT_EQ(detect_input_format("# 01 03 00 00 00 02 C4 0B\n"), InputFormat::hex);
    EXPECT_EQ(detect_input_format(""), InputFormat::raw);
    // The sniffed head may end inside a UTF-8 character.
    EXPECT_EQ(detect_input_format("01 03 00 00 00 02 C4 0B\n\xE4\xB8"), InputFormat::hex);
}

// A logger that colours its lines (ESPHome's) writes escapes: the text is still a log.
TEST(SourcesDetect, ColouredTextIsALog) {
    EXPECT_EQ(detect_input_format("[20:22:02]\x1B[0;36m[D][uart_debug:114]: >>> "
                                  "06:03:00:00:00:02:C5:BC\x1B[0m\n"),
              InputFormat::hex);
    EXPECT_EQ(detect_input_format("01 03 00 00\x1B[0m\n"), InputFormat::hex);
    // The sniffed head may end inside an escape.
    EXPECT_EQ(detect_input_format("01 03 00 00\x1B[0;3"), InputFormat::hex);
}

// Every file the repository holds as an example of a format is detected as that format:
// each hex log as hex, and no capture, raw dump or pcap as a hex log.
TEST(SourcesDetect, EveryBundledFileIsDetectedAsItsFormat) {
    const std::vector<std::pair<std::string, InputFormat>> by_extension = {
        {".log", InputFormat::hex}, {".hex", InputFormat::hex},   {".rtucap", InputFormat::capture},
        {".bin", InputFormat::raw}, {".pcap", InputFormat::pcap}, {".pcapng", InputFormat::pcap},
    };
    std::size_t files = 0;
    std::size_t logs = 0;
    const std::filesystem::path root(RTUSCOPE_SOURCE_DIR);
    for (const char* dir : {"captures", "tests/data", "fuzz/corpus"}) {
        for (const auto& entry : std::filesystem::recursive_directory_iterator(root / dir)) {
            if (!entry.is_regular_file()) continue;
            const std::string ext = entry.path().extension().string();
            const auto expected = std::find_if(by_extension.begin(), by_extension.end(),
                                               [&](const auto& e) { return e.first == ext; });
            if (expected == by_extension.end()) continue;
            SCOPED_TRACE(entry.path().string());
            std::string head(4096, '\0');
            std::FILE* f = std::fopen(entry.path().c_str(), "rb");
            ASSERT_NE(f, nullptr);
            head.resize(std::fread(head.data(), 1, head.size(), f));
            std::fclose(f);
            EXPECT_EQ(detect_input_format(head), expected->second);
            ++files;
            if (expected->second == InputFormat::hex) ++logs;
        }
    }
    EXPECT_GT(files, 50U);
    EXPECT_GT(logs, 20U);
}

TEST(SourcesDetect, AutomaticFromMemoryPicksTheReader) {
    auto capture_source = from_memory(capture("1.0 01\n"), InputFormat::automatic);
    ASSERT_TRUE(capture_source);
    EXPECT_EQ(capture_source->info().format, "capture");
    auto hex_source = from_memory("TX 01 03 00 00 00 02 C4 0B\n", InputFormat::automatic);
    ASSERT_TRUE(hex_source);
    EXPECT_EQ(hex_source->info().format, "hex");
    auto raw_source = from_memory(std::string("\x01\x03\x00", 3), InputFormat::automatic);
    ASSERT_TRUE(raw_source);
    EXPECT_EQ(raw_source->info().format, "raw");
}

// --- files ----------------------------------------------------------------------------------

TEST(SourcesOpen, MissingFileAndDirectoryAreClearErrors) {
    TempDir dir;
    const std::string missing = dir.path() + "/nope.rtucap";
    auto a = open_source(missing, InputFormat::automatic);
    ASSERT_FALSE(a.ok());
    EXPECT_EQ(a.error().file, missing);
    EXPECT_EQ(a.error().to_string(), missing + ": cannot open: No such file or directory");
    auto b = open_source(dir.path(), InputFormat::capture);
    ASSERT_FALSE(b.ok());
    EXPECT_EQ(b.error().to_string(), dir.path() + ": is a directory");
}

TEST(SourcesOpen, PermissionDenied) {
    TempDir dir;
    const std::string file = dir.write("secret.rtucap", capture("1.0 01\n"));
    ASSERT_EQ(::chmod(file.c_str(), 0), 0);
    const std::string expected = file + ": cannot open: Permission denied";
    if (::geteuid() != 0) {
        auto source = open_source(file, InputFormat::automatic);
        ASSERT_FALSE(source.ok());
        EXPECT_EQ(source.error().to_string(), expected);
        return;
    }
    // Root reads every file: try as an unprivileged user in a child process.
    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
        if (::setgid(65534) != 0 || ::setuid(65534) != 0) ::_exit(2);
        auto source = open_source(file, InputFormat::automatic);
        ::_exit(!source.ok() && source.error().to_string() == expected ? 0 : 1);
    }
    int status = 0;
    ASSERT_EQ(::waitpid(child, &status, 0), child);
    ASSERT_TRUE(WIFEXITED(status));
    if (WEXITSTATUS(status) == 2) GTEST_SKIP() << "cannot drop root privileges here";
    EXPECT_EQ(WEXITSTATUS(status), 0) << "expected: " << expected;
}

TEST(SourcesOpen, DetectsAndReadsEachFormatFromFiles) {
    TempDir dir;
    const std::string cap = dir.write("a.rtucap", capture("# serial 9600 8E1\n1.5 01 02\n"));
    auto c = open_source(cap, InputFormat::automatic);
    ASSERT_TRUE(c.ok()) << c.error().to_string();
    EXPECT_EQ((*c)->info().format, "capture");
    EXPECT_EQ((*c)->info().name, cap);
    EXPECT_EQ((*c)->info().line->parity, 'E');
    Drained dc = drain(**c);
    ASSERT_EQ(dc.chunks.size(), 1U);
    EXPECT_EQ(dc.chunks[0].bytes, (Bytes{0x01, 0x02}));

    const std::string hex = dir.write("log.txt", "TX 01 03 00 00 00 02 C4 0B\nnothing\n");
    auto h = open_source(hex, InputFormat::automatic);
    ASSERT_TRUE(h.ok());
    EXPECT_EQ((*h)->info().format, "hex");
    Drained dh = drain(**h);
    ASSERT_EQ(dh.chunks.size(), 1U);
    EXPECT_EQ((*h)->remarks(), std::vector<std::string>{"skipped 1 line with no frame: 2"});

    std::string bytes(5000, '\x01');
    bytes[0] = '\0';
    const std::string raw = dir.write("dump.bin", bytes);
    auto r = open_source(raw, InputFormat::automatic);
    ASSERT_TRUE(r.ok());
    EXPECT_EQ((*r)->info().format, "raw");
    Drained dr = drain(**r);
    ASSERT_EQ(dr.chunks.size(), 2U);
    EXPECT_EQ(dr.chunks[0].bytes.size(), 4096U);
    EXPECT_EQ(dr.chunks[1].bytes.size(), 904U);
    EXPECT_EQ(dr.chunks[0].bytes[0], 0x00);
    EXPECT_EQ(dr.chunks[1].bytes[903], 0x01);

    // An empty file is a recording that never started: said so, in one line.
    const std::string empty = dir.write("empty", "");
    for (const InputFormat format : {InputFormat::automatic, InputFormat::capture}) {
        auto e = open_source(empty, format);
        ASSERT_FALSE(e.ok());
        EXPECT_EQ(e.error().to_string(), empty + ": is empty: nothing to decode");
    }
}

TEST(SourcesOpen, ForcedFormatOverridesDetection) {
    TempDir dir;
    const std::string file = dir.write("x.txt", "TX 01 03 00 00 00 02 C4 0B\n");
    auto r = open_source(file, InputFormat::raw);
    ASSERT_TRUE(r.ok());
    Drained d = drain(**r);
    ASSERT_EQ(d.chunks.size(), 1U);
    EXPECT_EQ(d.chunks[0].bytes.size(), 27U);
    auto c = open_source(file, InputFormat::capture);
    ASSERT_FALSE(c.ok());
    EXPECT_EQ(c.error().to_string(),
              file + ":1:1: not an rtuscope capture (line 1 must be \"# rtuscope capture v1\")");
}

TEST(SourcesOpen, StandardInputKeepsTheSniffedBytes) {
    // More than the 4 KiB used for detection, so the reader must carry on after them.
    TempDir dir;
    std::string log;
    for (int i = 0; i < 300; ++i) log += "RX 01 03 02 17 F8 B6 36\n";
    const std::string file = dir.write("stdin.txt", log);
    ASSERT_GT(log.size(), 4096U);

    const int saved = ::dup(STDIN_FILENO);
    const int fd = ::open(file.c_str(), O_RDONLY);
    ASSERT_GE(fd, 0);
    ::dup2(fd, STDIN_FILENO);
    ::close(fd);
    std::clearerr(stdin);
    auto source = open_source("-", InputFormat::automatic);
    Drained d;
    if (source.ok()) d = drain(**source);
    ::dup2(saved, STDIN_FILENO);
    ::close(saved);
    std::clearerr(stdin);

    ASSERT_TRUE(source.ok()) << source.error().to_string();
    EXPECT_EQ((*source)->info().name, "-");
    EXPECT_EQ((*source)->info().format, "hex");
    ASSERT_FALSE(d.error);
    ASSERT_EQ(d.chunks.size(), 300U);
    for (const Chunk& c : d.chunks) {
        ASSERT_EQ(c.bytes, (Bytes{0x01, 0x03, 0x02, 0x17, 0xF8, 0xB6, 0x36}));
    }
    EXPECT_EQ(d.chunks.back().source_line, 300);
}

TEST(SourcesOpen, GarbageNeverCrashesAReader) {
    // Every reader must turn arbitrary bytes into chunks or one error, never a crash.
    std::uint32_t state = 12345;
    const auto next_byte = [&] {
        state = state * 1103515245U + 12345U;
        return static_cast<char>(state >> 16);
    };
    const std::string alphabet = "0123456789abcdefABCDEF:. \t\n#/@*,>x-T";
    for (int round = 0; round < 200; ++round) {
        std::string text = round % 2 == 0 ? "# rtuscope capture v1\n" : "";
        for (int i = 0; i < 300; ++i) {
            const char c = next_byte();
            text += round % 3 == 0 ? c : alphabet[static_cast<unsigned char>(c) % alphabet.size()];
        }
        for (InputFormat format :
             {InputFormat::automatic, InputFormat::capture, InputFormat::hex, InputFormat::raw}) {
            auto source = source_from_memory(text, "fuzz", format);
            if (!source) continue;
            Drained d = drain(**source);
            for (const Chunk& c : d.chunks) {
                if (c.whole_frame) {
                    ASSERT_GE(c.bytes.size(), kMinAdu);
                }
                ASSERT_FALSE(c.bytes.empty());
            }
        }
    }
}

TEST(CaptureReader, StreamsALargeFileAcrossBufferBoundaries) {
    // Well over the reader's 64 KiB blocks, CRLF lines, a bad line near the end.
    TempDir dir;
    std::string content = "# rtuscope capture v1\r\n# serial 9600 8N1\r\n";
    const int lines = 20000;
    for (int i = 0; i < lines; ++i) {
        content += std::to_string(1000 + i) + "." + std::to_string(100000 + i) +
                   " @B 01 03 02 17 F8 B6 36\r\n";
    }
    content += "9999.5 01 zz\r\n";
    const std::string file = dir.write("big.rtucap", content);
    ASSERT_GT(content.size(), 3U * 65536U);
    auto source = open_source(file, InputFormat::automatic);
    ASSERT_TRUE(source.ok()) << source.error().to_string();
    Drained d = drain(**source);
    ASSERT_EQ(d.chunks.size(), static_cast<std::size_t>(lines));
    for (int i = 0; i < lines; ++i) {
        const Chunk& c = d.chunks[static_cast<std::size_t>(i)];
        ASSERT_EQ(c.source_line, i + 3);
        ASSERT_EQ(c.time, (1000 + i) * kNanosPerSecond + (100000 + i) * 1000);
        ASSERT_EQ(c.channel, "B");
        ASSERT_EQ(c.bytes, (Bytes{0x01, 0x03, 0x02, 0x17, 0xF8, 0xB6, 0x36}));
    }
    ASSERT_TRUE(d.error);
    EXPECT_EQ(d.error->to_string(),
              file + ":" + std::to_string(lines + 3) + ":11: bad hex byte \"zz\"");
}

TEST(CaptureReader, OverlongLineIsAnErrorNotAnEndlessBuffer) {
    TempDir dir;
    const std::string file =
        dir.write("huge.rtucap", capture("0.5 01\n1.0" + std::string(2u << 20, ' ') + "01\n"));
    auto source = open_source(file, InputFormat::capture);
    ASSERT_TRUE(source.ok());
    Drained d = drain(**source);
    EXPECT_EQ(d.chunks.size(), 1U);
    ASSERT_TRUE(d.error);
    EXPECT_EQ(d.error->to_string(),
              file + ":3: line longer than 1048576 bytes; is this a text file?");
}

}  // namespace
}  // namespace rtuscope

namespace rtuscope {
namespace {

// What a live run writes into a -w capture's header comes back when the capture is read:
// the line, the program, the device map and an embedded profile's text, line for line.
TEST(CaptureHeader, DeviceMapAndEmbeddedProfilesComeBack) {
    SourceInfo written;
    written.line = LineSettings{.baud = 19200};
    written.written_by = "rtuscope 0.1.0";
    written.devices = {{1, "zb-uvi485"}, {7, "my-meter"}};
    written.embedded_profiles = {{"my-meter", "[device]\nname = \"my-meter\"\n\n# a comment\n"}};
    written.name = "/dev/ttyUSB0";
    const std::string header = capture_header(written);
    auto source = source_from_memory(header + "1.000 01 03 00 00 00 02 C4 0B\n", "mem",
                                     InputFormat::automatic);
    ASSERT_TRUE(source) << source.error().to_string();
    const SourceInfo& read = (*source)->info();
    ASSERT_TRUE(read.line);
    EXPECT_EQ(read.line->baud, 19200U);
    EXPECT_EQ(read.written_by, "rtuscope 0.1.0");
    EXPECT_EQ(read.devices, written.devices);
    EXPECT_EQ(read.embedded_profiles, written.embedded_profiles);
    Chunk chunk;
    ASSERT_TRUE((*source)->next(chunk));
    EXPECT_EQ(chunk.bytes.size(), 8U);
}

TEST(CaptureHeader, BadDeviceLineIsAnErrorAtItsPlace) {
    auto source = source_from_memory("# rtuscope capture v1\n# device 300 pdu485\n", "mem",
                                     InputFormat::automatic);
    ASSERT_FALSE(source);
    EXPECT_EQ(source.error().to_string(),
              "mem:2:10: \"# device\" needs a slave address (0-255) and a profile name, e.g. "
              "\"# device 3 pdu485\"");
}

}  // namespace
}  // namespace rtuscope
