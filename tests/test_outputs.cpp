// The outputs (JSON Lines, text and CSV: their fields, and how they reach the file) and
// record filters, on the seed manual's frames and hand-made records.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "input/sources.hpp"
#include "output/fields.hpp"
#include "output/filter.hpp"
#include "output/sinks.hpp"
#include "pipeline.hpp"
#include "profiles/bus.hpp"
#include "support.hpp"

namespace rtuscope {
namespace {

// What `write` writes to a file, read back from memory.
template <class Write>
std::string written_to_memory(Write write) {
    char* buffer = nullptr;
    std::size_t size = 0;
    std::FILE* out = open_memstream(&buffer, &size);
    write(out);
    std::fclose(out);
    std::string text(buffer, size);
    std::free(buffer);
    return text;
}

// Runs the pipeline over `input` into a sink writing to a memory buffer.
template <class MakeSink>
std::string run_to_text(const std::string& input, const Bus* bus, MakeSink make_sink) {
    return written_to_memory([&](std::FILE* out) {
        auto source = source_from_memory(input, "mem", InputFormat::automatic);
        EXPECT_TRUE(source);
        PipelineOptions options;
        options.bus = bus;
        auto sink = make_sink(out);
        EXPECT_TRUE(run_pipeline(**source, options, *sink));
    });
}

// What a sink writes, between begin() and end(), for the records `feed` hands it.
template <class MakeSink, class Feed>
std::string sink_output(MakeSink make_sink, Feed feed) {
    return written_to_memory([&](std::FILE* out) {
        auto sink = make_sink(out);
        sink->begin(SessionInfo{});
        feed(*sink);
        sink->end(Totals{}, {});
    });
}

const char* const kZbFrames =
    "01 04 00 15 00 12 61 c3\n"  // set correction coefficient 1.8
    "01 04 00 15 00 12 61 c3\n"  // its echo
    "02 03 02 18 18 b6 4e\n"     // the manual's answer with a wrong CRC
    "01 83 02 c0 f1\n";          // an exception from a device that never sends one

TEST(Jsonl, OneObjectPerRecordWithDecodedFieldsAndValues) {
    Bus bus;
    ASSERT_TRUE(bus.assign(1, "zb-uvi485"));
    const std::string text = run_to_text(kZbFrames, &bus, make_jsonl_sink);
    std::vector<std::string> lines;
    for (std::size_t at = 0; at < text.size();) {
        const auto nl = text.find('\n', at);
        lines.push_back(text.substr(at, nl - at));
        at = nl + 1;
    }
    ASSERT_EQ(lines.size(), 4U);
    EXPECT_EQ(lines[0],
              R"({"frame":1,"time":null,"slave":1,"function":4,"kind":"request","crc":"ok",)"
              R"("request":null,"latency_ms":null,"summary":"Set correction coefficient 0x0015 = )"
              R"(0x0012","hex":"01040015001261C3","flags":[],"notes":[],"channel":null,)"
              R"("function_name":"Set correction coefficient","exception":null,)"
              R"("profile":"zb-uvi485","values":[{"address":21,"name":"correction_coefficient",)"
              R"("value":1.8,"unit":"","raw":"0x0012","flags":[],"notes":[]}],)"
              R"("transport":"rtu","transaction":null})");
    EXPECT_NE(lines[1].find(R"("kind":"response","crc":"ok","request":1,)"), std::string::npos);
    // Slave 2 has no profile: no values, and the bad CRC is in the flags.
    EXPECT_NE(lines[2].find(R"("kind":"invalid","crc":"bad",)"), std::string::npos);
    EXPECT_NE(lines[2].find(R"("flags":["frame.crc_mismatch"],)"), std::string::npos) << lines[2];
    EXPECT_NE(lines[2].find(R"("profile":null,"values":[],)"), std::string::npos);
    EXPECT_NE(lines[3].find(R"("exception":{"code":2,"name":"Illegal Data Address"})"),
              std::string::npos)
        << lines[3];
    EXPECT_NE(lines[3].find("txn.unexpected_exception"), std::string::npos);
}

std::string json(std::string_view text) {
    std::string out;
    append_json_string(out, text);
    return out;
}

// Printable ASCII goes through a shortcut: each character that needs escaping must still
// be escaped, alone in a string of plain ones (a channel tag, a profile's names and units,
// a file name may hold any of them).
TEST(Jsonl, StringsAreEscaped) {
    EXPECT_EQ(json("plain text"), R"("plain text")");
    EXPECT_EQ(json("a\"b\\c\nd\x01"), R"("a\"b\\c\nd\u0001")");
    EXPECT_EQ(json("a\x1F-\r\t"), R"("a\u001f-\r\t")");
    EXPECT_EQ(json("\x7F"), "\"\x7F\"");
    EXPECT_EQ(json("µW/cm²"), "\"µW/cm²\"");
    EXPECT_EQ(json("@port\\1"), R"("@port\\1")");
    // Not UTF-8 (a Latin-1 file name, a cut sequence, a surrogate): U+FFFD per byte.
    EXPECT_EQ(json("caf\xe9"), "\"caf\xEF\xBF\xBD\"");
    EXPECT_EQ(json("\xc3"), "\"\xEF\xBF\xBD\"");
    EXPECT_EQ(json("\xed\xa0\x80"), "\"\xEF\xBF\xBD\xEF\xBF\xBD\xEF\xBF\xBD\"");
    std::string out = "{";
    append_json_string(out, "bad \xFF");
    EXPECT_EQ(out, "{\"bad \xEF\xBF\xBD\"");
}

// The text's time column: time of day for absolute Unix times (here -t u), seconds since
// the first frame (-t r), seconds since the previous frame (-t d).
TEST(Text, TimeColumnAbsoluteRelativeAndDelta) {
    const std::string capture =
        "# rtuscope capture v1\n# serial 9600 8N1\n"
        "1763798400.010000000 01 03 00 00 00 02 C4 0B\n"
        "1763798400.250000000 01 03 00 00 00 02 C4 0B\n"
        "1763798400.300000000 01 03 00 00 00 02 C4 0B\n";
    auto time_column = [&](TimeFormat format) {
        const std::string text = run_to_text(capture, nullptr, [&](std::FILE* out) {
            return make_text_sink(out, TextOptions{false, false, format});
        });
        std::vector<std::string> times;
        for (std::size_t at = text.find('\n') + 1; at < text.size();) {
            const auto nl = text.find('\n', at);
            const std::string line = text.substr(at, nl - at);
            if (line.rfind("--", 0) != 0) times.push_back(line.substr(6, 15));
            at = nl + 1;
        }
        return times;
    };
    // 8 bytes at 9600 baud take 8.333 ms: the frames start at .001667, .241667, .291667.
    EXPECT_EQ(time_column(TimeFormat::utc),
              (std::vector<std::string>{"08:00:00.001667", "08:00:00.241667", "08:00:00.291667"}));
    EXPECT_EQ(time_column(TimeFormat::relative),
              (std::vector<std::string>{"       0.000000", "       0.240000", "       0.290000"}));
    EXPECT_EQ(time_column(TimeFormat::delta),
              (std::vector<std::string>{"       0.000000", "       0.240000", "       0.050000"}));
}

// Central European time and its summer time, as a POSIX rule: no tzdata needed.
using test::ScopedZone;

constexpr const char* kBerlin = "CET-1CEST,M3.5.0,M10.5.0/3";

// The text's lines after the header and before the closing summary: date lines and
// records, each record cut after its time column and the slave.
std::vector<std::string> time_lines(const std::string& input, TimeFormat format) {
    const std::string text = run_to_text(input, nullptr, [&](std::FILE* out) {
        return make_text_sink(out, TextOptions{false, false, format});
    });
    std::vector<std::string> lines;
    for (std::size_t at = text.find('\n') + 1; at < text.size();) {
        const auto nl = text.find('\n', at);
        std::string line = text.substr(at, nl - at);
        at = nl + 1;
        if (line.starts_with("-- ") && line.find("records,") != std::string::npos) break;
        if (!line.starts_with("--")) line = line.substr(0, line.find("  ", 8) + 5);
        lines.push_back(line);
    }
    return lines;
}

// Requests around midnight in Berlin (23:00 UTC) and in UTC, 2026-11-21; each line's time
// is its last byte's end, 8.333 ms after the frame's start.
const char* const kAroundMidnight =
    "# rtuscope capture v1\n# serial 9600 8N1\n"
    "1795301999.508333334 01 03 00 00 00 02 C4 0B\n"
    "1795302000.508333334 01 03 00 00 00 02 C4 0B\n"
    "1795305599.508333334 01 03 00 00 00 02 C4 0B\n"
    "1795305600.508333334 01 03 00 00 00 02 C4 0B\n";

TEST(Text, LocalTimeWithTheDateWhenItChanges) {
    const ScopedZone zone(kBerlin);
    EXPECT_EQ(
        time_lines(kAroundMidnight, TimeFormat::local),
        (std::vector<std::string>{"-- 2026-11-21 CET (UTC+01:00)", "    1 23:59:59.500000    1",
                                  "-- 2026-11-22 CET (UTC+01:00)", "    2 00:00:00.500000    1",
                                  "    3 00:59:59.500000    1", "    4 01:00:00.500000    1"}));
    EXPECT_EQ(
        time_lines(kAroundMidnight, TimeFormat::local_date),
        (std::vector<std::string>{
            "    1 2026-11-21 23:59:59.500000    1", "    2 2026-11-22 00:00:00.500000    1",
            "    3 2026-11-22 00:59:59.500000    1", "    4 2026-11-22 01:00:00.500000    1"}));
}

TEST(Text, UtcTimeWithTheDateWhenItChanges) {
    const ScopedZone zone(kBerlin);  // not used
    EXPECT_EQ(time_lines(kAroundMidnight, TimeFormat::utc),
              (std::vector<std::string>{"-- 2026-11-21 UTC", "    1 22:59:59.500000    1",
                                        "    2 23:00:00.500000    1", "    3 23:59:59.500000    1",
                                        "-- 2026-11-22 UTC", "    4 00:00:00.500000    1"}));
    EXPECT_EQ(
        time_lines(kAroundMidnight, TimeFormat::utc_date),
        (std::vector<std::string>{
            "    1 2026-11-21 22:59:59.500000    1", "    2 2026-11-21 23:00:00.500000    1",
            "    3 2026-11-21 23:59:59.500000    1", "    4 2026-11-22 00:00:00.500000    1"}));
    EXPECT_EQ(
        time_lines(kAroundMidnight, TimeFormat::epoch),
        (std::vector<std::string>{"    1 1795301999.500000    1", "    2 1795302000.500000    1",
                                  "    3 1795305599.500000    1", "    4 1795305600.500000    1"}));
}

// Summer time ends at 01:00 UTC on 2026-10-25: the hour from 02:00 comes twice, told
// apart by the zone line.
TEST(Text, ANewZoneLineWhenSummerTimeEnds) {
    const ScopedZone zone(kBerlin);
    const std::string capture =
        "# rtuscope capture v1\n# serial 9600 8N1\n"
        "1792889999.508333334 01 03 00 00 00 02 C4 0B\n"
        "1792890000.508333334 01 03 00 00 00 02 C4 0B\n";
    EXPECT_EQ(
        time_lines(capture, TimeFormat::local),
        (std::vector<std::string>{"-- 2026-10-25 CEST (UTC+02:00)", "    1 02:59:59.500000    1",
                                  "-- 2026-10-25 CET (UTC+01:00)", "    2 02:00:00.500000    1"}));
}

// A log's date and time without a zone, and a log's times of day, show as read in every
// zone and in UTC alike; -t e gives the CSV's seconds.
TEST(Text, TimesReadWithoutAZoneShowAsRead) {
    const ScopedZone zone(kBerlin);
    const std::string dated =
        "[2024-05-01 23:59:59.120] 01 03 00 00 00 02 C4 0B\n"
        "[2024-05-02 00:00:00.250] 01 03 00 00 00 02 C4 0B\n";
    const std::vector<std::string> as_read = {"-- 2024-05-01", "    1 23:59:59.120000    1",
                                              "-- 2024-05-02", "    2 00:00:00.250000    1"};
    EXPECT_EQ(time_lines(dated, TimeFormat::local), as_read);
    EXPECT_EQ(time_lines(dated, TimeFormat::utc), as_read);
    EXPECT_EQ(time_lines(dated, TimeFormat::local_date),
              (std::vector<std::string>{"    1 2024-05-01 23:59:59.120000    1",
                                        "    2 2024-05-02 00:00:00.250000    1"}));
    EXPECT_EQ(
        time_lines(dated, TimeFormat::epoch),
        (std::vector<std::string>{"    1 1714607999.120000    1", "    2 1714608000.250000    1"}));

    const std::string times_of_day =
        "[09:00:00.480] 01 03 00 00 00 02 C4 0B\n"
        "[23:59:59.900] 01 03 00 00 00 02 C4 0B\n"
        "[00:00:00.100] 01 03 00 00 00 02 C4 0B\n";
    const std::vector<std::string> day_lines = {
        "    1 09:00:00.480000    1", "    2 23:59:59.900000    1",
        "-- day 2 (the log's times have no date)", "    3 00:00:00.100000    1"};
    for (const TimeFormat format :
         {TimeFormat::local, TimeFormat::local_date, TimeFormat::utc, TimeFormat::utc_date}) {
        EXPECT_EQ(time_lines(times_of_day, format), day_lines);
    }
    EXPECT_EQ(time_lines(times_of_day, TimeFormat::epoch),
              (std::vector<std::string>{"    1    32400.480000    1", "    2    86399.900000    1",
                                        "    3    86400.100000    1"}));
}

// The latency is written without floating point; it must read exactly as fmt's rounding
// of ns / 1e6 would have it (3 decimals in CSV, 2 in text), halfway cases and signs
// included.
TEST(Outputs, LatencyReadsAsFmtRoundsTheMilliseconds) {
    std::vector<Nanos> latencies = {0,
                                    1,
                                    499,
                                    500,
                                    501,
                                    999,
                                    1'000,
                                    1'499,
                                    1'500,
                                    1'501,
                                    5'000,
                                    15'000,
                                    62'500,
                                    125'000,
                                    4'999'500,
                                    -1,
                                    -500,
                                    -4'000,
                                    -5'000,
                                    -62'500,
                                    86'805'555,
                                    1'234'567'891,
                                    (Nanos{1} << 40) + 500,
                                    3'600'000'000'000};
    std::mt19937_64 random(7);
    for (int i = 0; i < 3000; ++i) {
        latencies.push_back(static_cast<Nanos>(random() % 3'000'000'000) - 500'000'000);
    }
    auto written = [&](auto make_sink) {
        return sink_output(make_sink, [&](RecordSink& sink) {
            Record r;
            r.kind = Kind::response;
            r.request_number = 1;
            for (const Nanos latency : latencies) {
                ++r.number;
                r.latency = latency;
                sink.record(r);
            }
        });
    };

    const std::string csv = written([](std::FILE* out) { return make_csv_sink(out); });
    std::vector<std::string> csv_latencies;
    for (std::size_t at = csv.find('\n') + 1; at < csv.size(); at = csv.find('\n', at) + 1) {
        std::size_t field = at;
        for (int i = 0; i < 7; ++i) field = csv.find(',', field) + 1;
        csv_latencies.push_back(csv.substr(field, csv.find(',', field) - field));
    }
    const std::string text = written([](std::FILE* out) {
        return make_text_sink(out, TextOptions{false, false, TimeFormat::local});
    });
    std::vector<std::string> text_latencies;
    for (std::size_t at = text.find(" ms after #"); at != std::string::npos;
         at = text.find(" ms after #", at + 1)) {
        const std::size_t from = text.rfind(' ', at - 1) + 1;
        text_latencies.push_back(text.substr(from, at - from));
    }

    ASSERT_EQ(csv_latencies.size(), latencies.size());
    ASSERT_EQ(text_latencies.size(), latencies.size());
    for (std::size_t i = 0; i < latencies.size(); ++i) {
        const double ms = static_cast<double>(latencies[i]) / 1e6;
        EXPECT_EQ(csv_latencies[i], fmt::format("{:.3f}", ms)) << latencies[i] << " ns";
        EXPECT_EQ(text_latencies[i], fmt::format("{:.2f}", ms)) << latencies[i] << " ns";
    }
}

// The CSV keeps a time's whole seconds written while they stay the same: each time must
// still read as its own, across seconds, digit counts, no time and times before 1970.
TEST(Csv, TimeColumnIsEachRecordsOwnTime) {
    std::vector<Nanos> times = {1'763'798'400'011'139'000,
                                1'763'798'400'999'999'499,
                                1'763'798'400'999'999'500,  // rounds up into the next second
                                1'763'798'401'000'000'000,
                                kNoTime,
                                1'763'798'401'500'000'000,
                                5'000'000'000,
                                9'999'999'999,
                                10'000'000'000,
                                0,
                                499,
                                -1,
                                -1'500'000'000,
                                1'763'798'401'500'000'000,
                                9'999'999'999};
    std::mt19937_64 random(11);
    Nanos t = 1'700'000'000'000'000'000;
    for (int i = 0; i < 3000; ++i) {
        t += static_cast<Nanos>(random() % 5'000'000);  // a few hundred records a second
        times.push_back(t);
    }
    const std::string csv = sink_output(make_csv_sink, [&](RecordSink& sink) {
        Record r;
        r.kind = Kind::noise;
        for (const Nanos time : times) {
            r.frame.start = time;
            sink.record(r);
        }
    });
    std::vector<std::string> column;
    for (std::size_t at = csv.find('\n') + 1; at < csv.size(); at = csv.find('\n', at) + 1) {
        const std::size_t field = csv.find(',', at) + 1;
        column.push_back(csv.substr(field, csv.find(',', field) - field));
    }
    ASSERT_EQ(column.size(), times.size());
    for (std::size_t i = 0; i < times.size(); ++i) {
        std::string expected;
        if (has_time(times[i])) {
            // The sign, then the microseconds rounded half away from zero.
            const bool negative = times[i] < 0;
            const auto micros =
                (static_cast<std::uint64_t>(negative ? -times[i] : times[i]) + 500) / 1000;
            expected = fmt::format("{}{}.{:06}", negative ? "-" : "", micros / 1'000'000,
                                   micros % 1'000'000);
        }
        EXPECT_EQ(column[i], expected) << times[i] << " ns";
    }
}

// The CSV counts record numbers up by hand while they go up by one: each must still read
// as its own, across carries into a new digit, gaps (filtered records) and restarts.
TEST(Csv, NumberColumnIsEachRecordsOwnNumber) {
    std::vector<std::uint64_t> numbers;
    for (std::uint64_t n = 1; n <= 1200; ++n) numbers.push_back(n);
    for (const std::uint64_t n :
         {99'998ULL, 99'999ULL, 100'000ULL, 100'001ULL, 7ULL, 8ULL, 8ULL, 0ULL, 1ULL,
          18'446'744'073'709'551'614ULL, 18'446'744'073'709'551'615ULL, 0ULL, 9ULL, 10ULL}) {
        numbers.push_back(n);
    }
    const std::string csv = sink_output(make_csv_sink, [&](RecordSink& sink) {
        Record r;
        r.kind = Kind::noise;
        for (const std::uint64_t number : numbers) {
            r.number = number;
            sink.record(r);
        }
    });
    std::vector<std::string> column;
    for (std::size_t at = csv.find('\n') + 1; at < csv.size(); at = csv.find('\n', at) + 1) {
        column.push_back(csv.substr(at, csv.find(',', at) - at));
    }
    ASSERT_EQ(column.size(), numbers.size());
    for (std::size_t i = 0; i < numbers.size(); ++i) {
        EXPECT_EQ(column[i], std::to_string(numbers[i])) << "record " << i;
    }
}

// The CSV writer looks for the characters that need quotes 16 at a time, its last block
// overlapping the one before; the expected field here is RFC 4180 done the slow way.
// Texts of every length up to 40 with each of those characters (and other control
// characters, and non-ASCII bytes) at every position, so each falls in every place of a
// block, in the overlap and in texts too short for one.
TEST(Csv, QuotesExactlyTheFieldsThatHoldACommaAQuoteOrALineBreak) {
    std::vector<std::string> texts;
    const std::string kInserted[] = {
        ",",    "\"",   "\r",       "\n",       "\t",   std::string(1, '\0'),
        "\x0B", "\x0E", "\x0D\x0A", "\xC2\xB5", "\xFF", "\"\""};
    for (std::size_t length = 0; length <= 40; ++length) {
        std::string plain;
        for (std::size_t i = 0; i < length; ++i) plain += static_cast<char>('a' + i % 26);
        texts.push_back(plain);
        for (const std::string& inserted : kInserted) {
            for (std::size_t at = 0; at <= length; ++at) {
                texts.push_back(plain.substr(0, at) + inserted + plain.substr(at));
            }
        }
    }
    auto rfc4180 = [](const std::string& text) {
        if (text.find_first_of(std::string_view(",\"\r\n")) == std::string::npos) return text;
        std::string quoted = "\"";
        for (const char c : text) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
        return quoted + "\"";
    };

    // A frame's summary column is its function's name, a space and what it carries,
    // written from the two without joining them: either may hold what needs quotes.
    const std::string kNames[] = {"",    "Read Coils",         "a,b",
                                  "q\"", std::string(20, 'x'), std::string(20, 'y') + "\n"};

    const std::string csv = sink_output(make_csv_sink, [&](RecordSink& sink) {
        Record r;
        r.kind = Kind::noise;
        for (const std::string& text : texts) {
            r.notes.clear();
            r.notes.add("test.note", text);  // the notes column is the note's text
            sink.record(r);
        }
        r.kind = Kind::unknown;
        r.notes.clear();
        for (const std::string& name : kNames) {
            for (const std::string& text : texts) {
                r.decoded.function_name = name;
                r.decoded.summary = text;
                sink.record(r);
            }
        }
    });

    std::string expected = csv.substr(0, csv.find('\n') + 1);
    for (const std::string& text : texts) {
        // A noise record's summary has a comma of its own.
        expected += "0,,,,noise,,,,\"noise, 0 bytes\",,test.note," + rfc4180(text) + "\n";
    }
    for (const std::string& name : kNames) {
        for (const std::string& text : texts) {
            expected +=
                "0,,,,unknown,,,," + rfc4180(text.empty() ? name : name + " " + text) + ",,,\n";
        }
    }
    ASSERT_EQ(csv.size(), expected.size());
    EXPECT_TRUE(csv == expected);  // too long to print: the first difference follows
    const auto [mismatch, ignored] = std::mismatch(csv.begin(), csv.end(), expected.begin());
    EXPECT_EQ(csv.substr(static_cast<std::size_t>(mismatch - csv.begin()), 60),
              expected.substr(static_cast<std::size_t>(mismatch - csv.begin()), 60));
}

// A FILE* that keeps what reaches it through its write calls, and counts them.
class CountingFile {
  public:
    // `buffer` 0: unbuffered, every fwrite reaches on_write at once; else stdio holds up
    // to that many bytes, as it does for rtuscope's stdout into a file or a pipe.
    explicit CountingFile(std::size_t buffer) : buffer_(buffer) {
        const cookie_io_functions_t io{nullptr, &CountingFile::on_write, nullptr, nullptr};
        file_ = fopencookie(this, "w", io);
        EXPECT_NE(file_, nullptr);
        // With a null buffer glibc would keep its own size, whatever size was asked for.
        EXPECT_EQ(std::setvbuf(file_, buffer == 0 ? nullptr : buffer_.data(),
                               buffer == 0 ? _IONBF : _IOFBF, buffer),
                  0);
    }
    ~CountingFile() { std::fclose(file_); }
    CountingFile(const CountingFile&) = delete;
    CountingFile& operator=(const CountingFile&) = delete;

    [[nodiscard]] std::FILE* file() const { return file_; }
    [[nodiscard]] std::size_t writes() const { return writes_; }
    [[nodiscard]] const std::string& text() const { return text_; }

  private:
    static ssize_t on_write(void* cookie, const char* data, std::size_t size) {
        auto* self = static_cast<CountingFile*>(cookie);
        ++self->writes_;
        self->text_.append(data, size);
        return static_cast<ssize_t>(size);
    }

    std::vector<char> buffer_;
    std::FILE* file_ = nullptr;
    std::size_t writes_ = 0;
    std::string text_;
};

const std::pair<const char*, test::MakeSink> kRecordSinks[] = {
    {"text", [](std::FILE* f) { return make_text_sink(f, TextOptions{}); }},
    {"CSV", [](std::FILE* f) { return make_csv_sink(f); }},
    {"JSONL", [](std::FILE* f) { return make_jsonl_sink(f); }},
};

// `polls` reads of ten registers from slave 1, each answered, as a raw dump.
std::string answered_reads(int polls) {
    std::vector<test::Bytes> frames;
    for (int i = 0; i < polls; ++i) {
        test::Bytes answer = {0x01, 0x03, 20};
        for (int r = 0; r < 20; ++r) answer.push_back(static_cast<std::uint8_t>(i + r));
        frames.push_back(test::with_crc({0x01, 0x03, 0x00, 0x00, 0x00, 0x0A}));
        frames.push_back(test::with_crc(answer));
    }
    return test::raw_dump(frames);
}

// A decode hands its output to the file in blocks of 64 KiB (one write per record would
// cost a system call each when stdout is unbuffered or a terminal), not a record at a time,
// whatever buffering the file has.
TEST(Outputs, RecordsReachTheFileInLargeBlocks) {
    constexpr int kPolls = 2000;
    constexpr std::size_t kBlock = 64 << 10;
    for (const auto& [name, make_sink] : kRecordSinks) {
        CountingFile out(0);
        auto source = source_from_memory(answered_reads(kPolls), "mem", InputFormat::raw);
        ASSERT_TRUE(source);
        auto sink = make_sink(out.file());
        Totals totals;
        ASSERT_TRUE(run_pipeline(**source, {}, *sink, &totals));
        ASSERT_EQ(totals.records, 2U * kPolls) << name;
        ASSERT_GT(out.text().size(), 4 * kBlock) << name;
        // Full blocks, the last part of one, and the end's summary lines.
        EXPECT_LE(out.writes(), out.text().size() / kBlock + 8)
            << name << ": " << out.writes() << " writes of " << out.text().size() << " bytes";
    }
}

// Live, each record reaches the file when it is flushed: `rtuscope sniff > log` then
// `tail -f log` (stdout then has a 64 KiB stdio buffer) shows each frame as it comes, not
// 64 KiB later.
TEST(Outputs, AFlushHandsTheFileEverythingSoFar) {
    test::CollectingSink decoded;
    auto source = source_from_memory(answered_reads(3), "mem", InputFormat::raw);
    ASSERT_TRUE(source);
    ASSERT_TRUE(run_pipeline(**source, {}, decoded));
    ASSERT_EQ(decoded.records.size(), 6U);
    for (const auto& [name, make_sink] : kRecordSinks) {
        CountingFile out(std::size_t{64} << 10);
        auto sink = make_sink(out.file());
        sink->begin(SessionInfo{});
        std::size_t before = out.text().size();
        for (const Record& r : decoded.records) {
            sink->record(r);
            sink->flush();
            EXPECT_GT(out.text().size(), before) << name << ", record " << r.number;
            EXPECT_EQ(out.text().back(), '\n') << name << ", record " << r.number;
            before = out.text().size();
        }
        sink->end(Totals{}, {});
    }
}

TEST(Filter, ParsesListsKindsAndTimes) {
    const auto ranges = parse_ranges("1,3,10-20,0x10", 255);
    ASSERT_TRUE(ranges);
    EXPECT_EQ(*ranges, (RecordFilter::Ranges{{1, 1}, {3, 3}, {10, 20}, {16, 16}}));
    EXPECT_FALSE(parse_ranges("300", 255));
    EXPECT_FALSE(parse_ranges("5-3", 255));
    EXPECT_FALSE(parse_ranges("1,,2", 255));
    EXPECT_FALSE(parse_ranges("", 255));
    EXPECT_EQ(parse_kinds("responses").error().message,
              "unknown kind \"responses\" (request, response, exception, broadcast, unknown, "
              "invalid, noise, flagged)");
    const auto relative = parse_time_bound("+2.5");
    ASSERT_TRUE(relative);
    EXPECT_EQ(relative->nanos, 2'500'000'000);
    EXPECT_EQ(relative->kind, TimeBound::Kind::after_first);
    EXPECT_FALSE(parse_time_bound("yesterday"));
}

TEST(Filter, KeepsOnlyMatchingRecords) {
    const std::string frames = std::string(kZbFrames) + "03 03 00 00 00 01 85 e8\n";
    auto decode_with = [&](RecordFilter filter) {
        return run_to_text(frames, nullptr, [&](std::FILE* out) {
            return make_filter_sink(filter, make_csv_sink(out));
        });
    };
    auto rows = [](const std::string& csv) {
        std::vector<std::string> numbers;
        for (std::size_t at = csv.find('\n') + 1; at < csv.size();) {
            numbers.push_back(csv.substr(at, csv.find(',', at) - at));
            at = csv.find('\n', at) + 1;
        }
        return numbers;
    };
    RecordFilter by_slave;
    by_slave.slaves = {{2, 3}};
    EXPECT_EQ(rows(decode_with(by_slave)), (std::vector<std::string>{"3", "5"}));
    RecordFilter by_function;
    by_function.functions = {{3, 3}};  // the exception 0x83 counts as function 3
    EXPECT_EQ(rows(decode_with(by_function)), (std::vector<std::string>{"3", "4", "5"}));
    RecordFilter problems;
    problems.kinds = {"exception", "invalid"};
    EXPECT_EQ(rows(decode_with(problems)), (std::vector<std::string>{"3", "4"}));
    RecordFilter untimed;
    untimed.from = TimeBound{};  // hex logs have no times: nothing can be in a time range
    EXPECT_TRUE(rows(decode_with(untimed)).empty());
}

TEST(Filter, TimeRangeRelativeToTheFirstFrame) {
    const std::string capture =
        "# rtuscope capture v1\n# serial 9600 8N1\n"
        "10.000 01 03 00 00 00 01 84 0A\n"
        "11.000 01 03 00 00 00 01 84 0A\n"
        "12.000 01 03 00 00 00 01 84 0A\n";
    RecordFilter middle;
    middle.from = TimeBound{TimeBound::Kind::after_first, 900'000'000, {}};
    middle.to = TimeBound{TimeBound::Kind::seconds, 11'500'000'000, {}};  // the capture's
    const std::string csv = run_to_text(capture, nullptr, [&](std::FILE* out) {
        return make_filter_sink(middle, make_csv_sink(out));
    });
    EXPECT_EQ(csv.substr(csv.find('\n') + 1, 2), "2,");
    EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 2);
}

// --from/--to: what the output shows, as given.
TEST(Filter, ParsesEveryFormOfATime) {
    struct Case {
        const char* text;
        TimeBound::Kind kind;
        Nanos nanos;
        CivilDate date;
    };
    using K = TimeBound::Kind;
    const std::vector<Case> good = {
        {"08:00:01", K::time_of_day, 28'801'000'000'000, {}},
        {"23:59:59.123456789", K::time_of_day, 86'399'123'456'789, {}},
        {"2026-11-21 08:00:01", K::date_time, 28'801'000'000'000, {2026, 11, 21}},
        {"2026-11-21T08:00:01.25", K::date_time, 28'801'250'000'000, {2026, 11, 21}},
        {"2024-02-29 00:00:00", K::date_time, 0, {2024, 2, 29}},
        {"1795305600.5", K::seconds, 1'795'305'600'500'000'000, {}},
        {"12", K::seconds, 12'000'000'000, {}},
        {"+2.5", K::after_first, 2'500'000'000, {}},
    };
    for (const Case& c : good) {
        SCOPED_TRACE(c.text);
        const auto bound = parse_time_bound(c.text);
        ASSERT_TRUE(bound) << bound.error().message;
        EXPECT_EQ(bound->kind, c.kind);
        EXPECT_EQ(bound->nanos, c.nanos);
        EXPECT_EQ(bound->date.year, c.date.year);
        EXPECT_EQ(bound->date.month, c.date.month);
        EXPECT_EQ(bound->date.day, c.date.day);
    }
    for (const char* bad :
         {"24:00:00", "8:00:01", "08:00", "08:60:00", "08:00:01.", "08:00:01.1234567890",
          "08:00:01 ", "2026-02-29 08:00:00", "2026-11-21 08:00:01Z", "2026-11-21_08:00:01",
          "1899-12-31 23:00:00", "-5", "1e99", "+", "", "2026-11-21"}) {
        EXPECT_FALSE(parse_time_bound(bad)) << bad;
    }
    EXPECT_EQ(parse_time_bound("25:00:00").error().message,
              "bad time \"25:00:00\" (a time of day 08:00:01.5, a date and time 2026-11-21 "
              "08:00:01, seconds as in the CSV time column, or +S after the first frame)");
}

// A time of day is on the first record's day, or the next day if it is earlier than the
// first record's time of day; local time for absolute times, as read for times read
// without a zone.
TEST(Filter, PlacesTimesOfDayAndDatesOnTheInputsTimes) {
    auto place = [](const char* text, TimeBase base, Nanos first) {
        return parse_time_bound(text)->place(base, first);
    };
    const Nanos s = kNanosPerSecond;
    // 2026-11-21 22:59:59.5 UTC, 23:59:59.5 in Berlin.
    const Nanos first = 1'795'301'999 * s + s / 2;
    {
        const ScopedZone zone(kBerlin);
        EXPECT_EQ(place("00:00:00", TimeBase::unix_time, first), 1'795'302'000 * s);
        EXPECT_EQ(place("23:59:59.6", TimeBase::unix_time, first), first + s / 10);
        EXPECT_EQ(place("23:59:59.5", TimeBase::unix_time, first), first);  // same day
        EXPECT_EQ(place("2026-11-22 00:00:00", TimeBase::unix_time, first), 1'795'302'000 * s);
        // Summer time: 2026-07-01 12:00 in Berlin is 10:00 UTC.
        EXPECT_EQ(place("2026-07-01 12:00:00", TimeBase::unix_time, first),
                  (days_from_civil(2026, 7, 1) * 86'400 + 10 * 3600) * s);
    }
    {
        const ScopedZone zone("UTC");
        EXPECT_EQ(place("00:00:00", TimeBase::unix_time, first), 1'795'305'600 * s);
        EXPECT_EQ(place("23:00:00", TimeBase::unix_time, first), 1'795'302'000 * s);
    }
    // A log's date and time, as read whatever the zone.
    const ScopedZone zone(kBerlin);
    const Nanos day = days_from_civil(2024, 5, 1) * kNanosPerDay;
    const Nanos log_first = day + 37'293 * s + 120'000'000;  // 10:21:33.120
    EXPECT_EQ(place("10:21:34", TimeBase::wall_clock, log_first), day + 37'294 * s);
    EXPECT_EQ(place("09:00:00", TimeBase::wall_clock, log_first), day + kNanosPerDay + 32'400 * s);
    EXPECT_EQ(place("2024-05-01 10:00:00", TimeBase::wall_clock, log_first), day + 36'000 * s);
    // A log's times of day: its first day, or the next.
    EXPECT_EQ(place("09:00:01", TimeBase::time_of_day, 32'400 * s), 32'401 * s);
    EXPECT_EQ(place("08:00:00", TimeBase::time_of_day, 32'400 * s), kNanosPerDay + 28'800 * s);
    // Seconds and +S are the same on any times.
    EXPECT_EQ(place("12.5", TimeBase::relative, s), 12'500'000'000);
    EXPECT_EQ(place("+2", TimeBase::relative, s), 3 * s);
    // No clock, no date: not placed, and the command line says why.
    EXPECT_FALSE(place("08:00:00", TimeBase::relative, s));
    EXPECT_FALSE(place("2024-05-01 10:00:00", TimeBase::time_of_day, s));
    EXPECT_EQ(check_time_bound(*parse_time_bound("08:00:00"), TimeBase::relative).error().message,
              "the input's times are relative seconds, with no clock: give seconds as in the "
              "CSV time column, or +S after the first frame");
    EXPECT_EQ(check_time_bound(*parse_time_bound("2024-05-01 10:00:00"), TimeBase::time_of_day)
                  .error()
                  .message,
              "the input's times have no date: give a time of day (08:00:01)");
    EXPECT_TRUE(check_time_bound(*parse_time_bound("08:00:00"), TimeBase::none));
}

TEST(Filter, TimeOfDayRangeInTheLocalZone) {
    const ScopedZone zone(kBerlin);
    RecordFilter after_midnight;  // in Berlin: the three requests from 00:00 to 01:00:00.6
    after_midnight.from = *parse_time_bound("00:00:00");
    after_midnight.to = *parse_time_bound("01:00:00.6");
    const std::string csv = run_to_text(kAroundMidnight, nullptr, [&](std::FILE* out) {
        return make_filter_sink(after_midnight, make_csv_sink(out));
    });
    std::vector<std::string> numbers;
    for (std::size_t at = csv.find('\n') + 1; at < csv.size(); at = csv.find('\n', at) + 1) {
        numbers.push_back(csv.substr(at, csv.find(',', at) - at));
    }
    EXPECT_EQ(numbers, (std::vector<std::string>{"2", "3", "4"}));
}

}  // namespace
}  // namespace rtuscope
