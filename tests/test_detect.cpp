// Finding a line's settings: the character-time estimator shared with decode's warning,
// one setting's score, and the detector's plan and ranking over listeners that hear
// a known line as each setting would.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <map>
#include <random>

#include "detect/detect.hpp"
#include "framing/char_time.hpp"
#include "input/sources.hpp"
#include "input/tty.hpp"
#include "sim/uart_model.hpp"
#include "support.hpp"

namespace rtuscope {
namespace {

using test::Bytes;
using test::with_crc;

// A request and its answer, over and over: `cycles` of them, per byte at `line`'s
// character time (plus `pause` between characters), 5 ms between frames.
std::vector<Chunk> polled_line(const LineSettings& line, int cycles, Nanos pause = 0,
                               Nanos start = 0) {
    std::vector<Chunk> chunks;
    Nanos now = start;
    const auto send = [&](const Bytes& frame) {
        for (const std::uint8_t b : frame) {
            now += line.char_time() + pause;
            chunks.push_back({now, "", {b}, 0, {}});
        }
        now += 5 * test::kMs;
    };
    for (int i = 0; i < cycles; ++i) {
        send(with_crc({1, 3, 0, 0, 0, 2}));
        send(with_crc({1, 3, 4, 0x08, 0x9D, 0, static_cast<std::uint8_t>(i)}));
    }
    return chunks;
}

std::vector<Chunk> garbage(std::size_t bytes, std::uint32_t seed, Nanos spacing = 1'000'000) {
    std::mt19937 random(seed);
    std::vector<Chunk> chunks;
    for (std::size_t i = 0; i < bytes; ++i) {
        chunks.push_back({static_cast<Nanos>(i + 1) * spacing, "",
                          {static_cast<std::uint8_t>(random())}, 0, {}});
    }
    return chunks;
}

LineSettings setting(std::uint32_t baud, std::string_view format) {
    LineSettings line = *parse_line_format(format);
    line.baud = baud;
    return line;
}

TEST(CharTimeEstimator, FindsTheSpacingMostBackToBackBytesKeep) {
    const LineSettings line = setting(9600, "8E1");
    CharTimeEstimator estimator;
    for (const Chunk& c : polled_line(line, 10)) estimator.chunk(c);
    const auto estimate = estimator.estimate();
    ASSERT_TRUE(estimate.has_value());
    EXPECT_EQ(estimate->char_time, line.char_time());
    // 9 of the 10 bytes of each request and answer pair follow the one before directly.
    EXPECT_EQ(estimate->measured, 10U * 17U - 1U);
    EXPECT_EQ(estimate->intervals, 10U * 15U);
}

TEST(CharTimeEstimator, ToleratesAReaderWokenLateAndIgnoresBatches) {
    // Every byte stamped up to 40 µs late: the spacing still shows within 3 %.
    const LineSettings line = setting(19200, "8N1");
    std::mt19937 random(7);
    CharTimeEstimator estimator;
    for (Chunk c : polled_line(line, 20)) {
        c.time += static_cast<Nanos>(random() % 40'000);
        estimator.chunk(c);
    }
    const auto estimate = estimator.estimate();
    ASSERT_TRUE(estimate.has_value());
    EXPECT_NEAR(static_cast<double>(estimate->char_time), static_cast<double>(line.char_time()),
                0.03 * static_cast<double>(line.char_time()));

    // Chunks of several bytes time no single character.
    CharTimeEstimator batches;
    test::Line usb(line);
    for (int i = 0; i < 50; ++i) usb.send_chunk({1, 3, 0, 0}).silence(4);
    for (const Chunk& c : usb.chunks()) batches.chunk(c);
    EXPECT_FALSE(batches.estimate().has_value());
}

TEST(CharTimeFit, NamesTheRateAndCharacterLength) {
    const auto best = [](Nanos char_time) {
        const auto fits = fit_char_time(char_time);
        return fits.empty() ? std::string("none")
                            : fmt::format("{}/{}", fits.front().baud, fits.front().bits_per_char);
    };
    EXPECT_EQ(best(setting(9600, "8N1").char_time()), "9600/10");
    EXPECT_EQ(best(setting(9600, "8E1").char_time()), "9600/11");
    EXPECT_EQ(best(setting(19200, "8N2").char_time()), "19200/11");
    EXPECT_EQ(best(setting(115200, "8O2").char_time()), "115200/12");
    EXPECT_EQ(best(setting(1200, "7E1").char_time()), "1200/10");
    EXPECT_EQ(best(1'144'000), "9600/11");  // the flow meter's captures
    EXPECT_EQ(best(1'350'000), "none");  // 13 bits at 9600, 19.4 at 14400
}

// Captures timed one byte a line, as a logic analyser's export gives them, at every rate
// detect tries and every format: read back through the capture reader, their timing
// gives the rate and the character length.
TEST(CharTimeFit, GeneratedCapturesAtEveryRateAndFormat) {
    for (const std::uint32_t baud : default_bauds()) {
        for (const LineSettings& format : default_formats(true)) {
            LineSettings line = format;
            line.baud = baud;
            std::string capture = "# rtuscope capture v1\n# serial 9600 8N1\n";
            for (const Chunk& c : polled_line(line, 4)) {
                capture += fmt::format("{:.9f} {:02X}\n", static_cast<double>(c.time) / 1e9,
                                       c.bytes[0]);
            }
            auto source = source_from_memory(capture, "generated", InputFormat::capture);
            ASSERT_TRUE(source) << source.error().to_string();
            CharTimeEstimator estimator;
            Chunk chunk;
            while (*(*source)->next(chunk)) estimator.chunk(chunk);
            const auto estimate = estimator.estimate();
            ASSERT_TRUE(estimate.has_value()) << baud << " " << line.format();
            const auto fits = fit_char_time(estimate->char_time);
            ASSERT_FALSE(fits.empty()) << baud << " " << line.format();
            EXPECT_EQ(fits.front().baud, baud) << line.format();
            EXPECT_EQ(fits.front().bits_per_char, line.bits_per_char()) << baud << " " << line.format();
        }
    }
}

TEST(ScoreSetting, ARightSettingFramesPairsAndFitsItsTiming) {
    const LineSettings line = setting(9600, "8E1");
    const auto chunks = polled_line(line, 6);
    const SettingScore right = score_setting(line, chunks, kNanosPerSecond);
    // The first request and the last answer, which listening may have cut, are left out:
    // the first answer then answers no request heard.
    EXPECT_EQ(right.frames, 10U);
    EXPECT_EQ(right.bytes, 5U * 8U + 5U * 9U);
    EXPECT_EQ(right.paired, 4U);
    EXPECT_DOUBLE_EQ(right.coverage(), 1.0);
    EXPECT_EQ(right.timing_fit, TimingFit::exact);
    EXPECT_DOUBLE_EQ(right.score, 100.0);

    // The same bytes at 8N1 (the parity bit taken for the stop bit): the spacing says
    // the characters are longer than this format's.
    const SettingScore shorter = score_setting(setting(9600, "8N1"), chunks, kNanosPerSecond);
    EXPECT_EQ(shorter.frames, 10U);
    EXPECT_EQ(shorter.timing_fit, TimingFit::slower);
    EXPECT_LT(shorter.score, right.score);
    // At 8E2 they come sooner than its characters last: not it.
    const SettingScore longer = score_setting(setting(9600, "8E2"), chunks, kNanosPerSecond);
    EXPECT_EQ(longer.timing_fit, TimingFit::faster);
    EXPECT_LT(longer.score, 40.0);
}

TEST(ScoreSetting, PiecesOfFramesAtTheEdgesOfALoadedReadAreNotJudged) {
    // A reader woken late on a loaded machine stamps the rest of a frame as if after a
    // silence: the bursts left out at the start and end of listening then end and begin
    // inside frames, and a piece of one is left at each edge.
    const LineSettings line = setting(9600, "8N2");
    auto chunks = polled_line(line, 6);
    const auto woken_late = [&](std::size_t from) {
        for (std::size_t i = from; i < chunks.size(); ++i) chunks[i].time += 10 * test::kMs;
    };
    woken_late(3);                  // the first request's last 5 bytes
    woken_late(chunks.size() - 3);  // the last answer's first 6 bytes stay before it
    const SettingScore s = score_setting(line, chunks, kNanosPerSecond);
    EXPECT_EQ(s.edge_bytes, 5U + 6U);
    EXPECT_DOUBLE_EQ(s.coverage(), 1.0);
    EXPECT_DOUBLE_EQ(s.score, 100.0);
    // Read whole, a recording's edges are judged as they are.
    EXPECT_EQ(score_setting(line, chunks, kNanosPerSecond, true).edge_bytes, 0U);
}

TEST(ScoreSetting, AFramePartedByMoreThanOneLateWakeIsOnePieceAtAnEdge) {
    // Woken late twice inside the first request and twice inside the last answer: each
    // edge holds two records, together less than a frame.
    const LineSettings line = setting(9600, "8N2");
    auto chunks = polled_line(line, 6);
    const auto woken_late = [&](std::size_t from) {
        for (std::size_t i = from; i < chunks.size(); ++i) chunks[i].time += 10 * test::kMs;
    };
    woken_late(3);
    woken_late(5);
    woken_late(chunks.size() - 6);
    woken_late(chunks.size() - 3);
    const SettingScore s = score_setting(line, chunks, kNanosPerSecond);
    EXPECT_EQ(s.edge_bytes, 5U + 6U);
    EXPECT_DOUBLE_EQ(s.coverage(), 1.0);
    EXPECT_DOUBLE_EQ(s.score, 100.0);
}

TEST(ScoreSetting, ErrorsThePortReportsAndGarbageScoreLow) {
    const LineSettings line = setting(9600, "8N1");
    auto chunks = polled_line(line, 6);
    const SettingScore clean = score_setting(line, chunks, kNanosPerSecond);
    // Every other byte with a framing error, as an 8N1 receiver reports 8E1 traffic.
    for (std::size_t i = 0; i < chunks.size(); i += 2) chunks[i].char_errors = {0};
    const SettingScore errors = score_setting(line, chunks, kNanosPerSecond);
    EXPECT_NEAR(static_cast<double>(errors.char_errors), static_cast<double>(errors.bytes) / 2, 1.0);
    EXPECT_LT(errors.score, 0.6 * clean.score);

    const SettingScore noise = score_setting(line, garbage(300, 1), kNanosPerSecond);
    EXPECT_EQ(noise.bytes, 300U);
    EXPECT_LT(noise.score, 10.0);
    EXPECT_EQ(score_setting(line, {}, kNanosPerSecond).score, 0.0);
}

// A line as each setting hears it: its traffic where `reads` says so (with the errors
// given), garbage elsewhere; every listen takes a second of the line's time.
struct FakeLine {
    std::map<std::string, std::uint64_t> reads;  // "19200 8E1" -> errors marked
    std::vector<std::string> heard;              // the settings listened to, in order
    bool quiet = false;

    Listen listen() {
        return [this](const LineSettings& line, Nanos most, const auto& /*enough*/,
                      std::vector<Chunk>& out) -> Result<Nanos> {
            const std::string name = fmt::format("{} {}", line.baud, line.format());
            heard.push_back(name);
            if (quiet) return most;
            const auto it = reads.find(name);
            if (it == reads.end()) {
                const auto noise = garbage(200, static_cast<std::uint32_t>(heard.size()));
                out.insert(out.end(), noise.begin(), noise.end());
            } else {
                auto chunks = polled_line(line, 8);
                for (std::uint64_t e = 0; e < it->second; ++e) {
                    chunks[(e * 7) % chunks.size()].char_errors = {0};
                }
                out.insert(out.end(), chunks.begin(), chunks.end());
            }
            return std::min(most, kNanosPerSecond);
        };
    }
};

TEST(DetectLine, FindsTheRateAtTheFirstFormatThenTriesTheOthersThereOnly) {
    FakeLine line;
    // 19200 8E1 traffic to a port that reports errors: an 8N1 receiver frames the bytes
    // but marks the parity bits read as stop bits; 8O1 marks every byte; 8N2 half.
    line.reads = {{"19200 8N1", 40}, {"19200 8E1", 0}, {"19200 8O1", 136}, {"19200 8N2", 40}};
    auto result = detect_line(line.listen(), DetectOptions{});
    ASSERT_TRUE(result) << result.error().to_string();
    EXPECT_EQ(line.heard, (std::vector<std::string>{"9600 8N1", "19200 8N1", "19200 8E1",
                                                    "19200 8O1", "19200 8N2"}));
    EXPECT_EQ(result->alike, 1U);
    EXPECT_EQ(result->chosen.format(), "8E1");
    EXPECT_EQ(result->chosen.baud, 19200U);
    EXPECT_EQ(result->confidence, "high");
    EXPECT_TRUE(result->errors_reported);
    const std::string text = format_detect_result(*result);
    EXPECT_NE(text.find("Best: 19200 8E1 (confidence high): 14 frames with a valid CRC hold "
                        "100 % of the bytes, 6 answers paired with their requests, no parity or "
                        "framing errors, bytes one 11-bit character apart."),
              std::string::npos)
        << text;
}

TEST(DetectLine, SettingsThatReadTheLineAlikeAreReportedTogether) {
    FakeLine line;
    // No errors reported, timing that fits 11-bit characters: 8E1, 8O1 and 8N2 alike.
    line.reads = {{"9600 8E1", 0}, {"9600 8O1", 0}, {"9600 8N2", 0}};
    DetectOptions options;
    options.bauds = {9600, 19200};
    auto result = detect_line(line.listen(), options);
    ASSERT_TRUE(result);
    // No rate reads well at 8N1: the other formats rate by rate, until one does.
    EXPECT_EQ(line.heard, (std::vector<std::string>{"9600 8N1", "19200 8N1", "9600 8E1",
                                                    "9600 8O1", "9600 8N2"}));
    EXPECT_EQ(result->alike, 3U);
    EXPECT_EQ(result->chosen.format(), "8E1");  // Modbus's default among them
    EXPECT_EQ(result->ranked[1].line.format(), "8N2");
    EXPECT_EQ(result->ranked[2].line.format(), "8O1");
    const std::string text = format_detect_result(*result);
    EXPECT_NE(text.find("At 9600 baud 8E1, 8N2 and 8O1 read this line alike (the port reported "
                        "no parity or framing errors to tell them apart); any of them decodes "
                        "it. 8E1 is chosen as the most usual."),
              std::string::npos)
        << text;
}

TEST(DetectLine, AQuietLineIsSaidToBeQuiet) {
    FakeLine line;
    line.quiet = true;
    DetectOptions options;
    options.quiet_wait = 2 * kNanosPerSecond;
    auto result = detect_line(line.listen(), options);
    ASSERT_TRUE(result);
    EXPECT_TRUE(result->quiet);
    EXPECT_EQ(result->alike, 0U);
    EXPECT_EQ(line.heard.size(), 1U);
    EXPECT_NE(format_detect_result(*result).find("No traffic in "), std::string::npos);
}

TEST(DetectLine, NothingPlausibleIsNoVerdictAndMaxSecondsCutsItShort) {
    FakeLine line;  // garbage at every setting
    DetectOptions options;
    options.max_total = 5 * kNanosPerSecond;
    auto result = detect_line(line.listen(), options);
    ASSERT_TRUE(result);
    EXPECT_EQ(result->alike, 0U);
    EXPECT_TRUE(result->cut_short);
    EXPECT_EQ(line.heard.size(), 5U);
    const std::string text = format_detect_result(*result);
    EXPECT_NE(text.find("No setting tried reads this line as Modbus RTU"), std::string::npos);
    EXPECT_NE(text.find("Stopped after 5.0 s (--max-seconds) with 5 settings tried."),
              std::string::npos);
}

// A line at `truth` as a port set to each candidate hears it with its errors marked:
// the characters a UART at the candidate setting receives, as the kernel hands them over
// with PARMRK (0xFF 0x00 X for a byte with a parity or framing error, 0xFF 0xFF for a data
// byte 0xFF), read back by the tty code's decoder one byte a read.
struct UartLine {
    LineSettings truth;
    std::vector<std::string> heard;

    Listen listen() {
        return [this](const LineSettings& line, Nanos most, const auto& /*enough*/,
                      std::vector<Chunk>& out) -> Result<Nanos> {
            heard.push_back(fmt::format("{} {}", line.baud, line.format()));
            sim::UartResampler uart(truth, line);
            Nanos end = 0;
            for (const Chunk& c : polled_line(truth, 8)) {
                const Nanos start = c.time - truth.char_time();
                uart.send(start, c.bytes[0]);
                end = c.time;
            }
            std::vector<sim::Received> received;
            uart.take_until(end + 10 * truth.char_time(), received);
            ParmrkDecoder parmrk;
            for (const sim::Received& r : received) {
                Bytes kernel;
                if (r.parity_error || r.framing_error) {
                    kernel = {0xFF, 0x00, r.byte};
                } else if (r.byte == 0xFF) {
                    kernel = {0xFF, 0xFF};
                } else {
                    kernel = {r.byte};
                }
                Chunk chunk;
                chunk.time = r.time;
                parmrk.feed(kernel, chunk.bytes, chunk.char_errors);
                out.push_back(std::move(chunk));
            }
            return std::min(most, kNanosPerSecond);
        };
    }
};

TEST(DetectLine, ErrorsMarkedByThePortTellParityAndStopBitsApart) {
    for (const char* format : {"8N1", "8E1", "8O1", "8N2"}) {
        UartLine line{setting(19200, format), {}};
        DetectOptions options;
        options.bauds = {9600, 19200, 115200};
        auto result = detect_line(line.listen(), options);
        ASSERT_TRUE(result) << result.error().to_string();
        const std::string report = format_detect_result(*result);
        EXPECT_EQ(result->alike, 1U) << report;
        EXPECT_EQ(fmt::format("{} {}", result->chosen.baud, result->chosen.format()),
                  fmt::format("19200 {}", format))
            << report;
    }
}

}  // namespace
}  // namespace rtuscope
