// Bus statistics: counts per slave/function, nearest-rank percentiles, poll cycles,
// utilisation on a timed capture, untimed input, and the CSV and JSONL outputs.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include "input/sources.hpp"
#include "profiles/bus.hpp"
#include "output/sinks.hpp"
#include "stats/health.hpp"
#include "stats/report.hpp"
#include "support.hpp"
#include "traffic.hpp"

namespace rtuscope {
namespace {

using test::Bytes;
using test::kMs;
using test::with_crc;

Record make_record(Kind kind, Bytes bytes, Nanos start = kNoTime, Nanos latency = kNoTime) {
    Record r;
    r.kind = kind;
    r.awaits_answer = kind == Kind::request;
    r.frame.bytes = std::move(bytes);
    r.frame.cls = kind == Kind::noise     ? RecordClass::noise
                  : kind == Kind::invalid ? RecordClass::invalid
                                          : RecordClass::frame;
    r.frame.crc = kind == Kind::noise ? CrcCheck{} : check_crc(r.frame.bytes);
    r.frame.start = start;
    if (has_time(start)) {
        r.frame.end = start + LineSettings{}.char_time() * static_cast<Nanos>(r.frame.bytes.size());
    }
    r.latency = latency;
    return r;
}

Record with_note(Record r, const char* id) {
    r.notes.add(id, "test");
    return r;
}

// Runs the whole pipeline on an in-memory input and returns the finished statistics
// (and the closing summary's totals in `totals`).
BusStats stats_of(std::string content, InputFormat format, const Bus* bus = nullptr,
                  Totals* totals = nullptr) {
    auto source = source_from_memory(std::move(content), "mem", format);
    EXPECT_TRUE(source) << source.error().to_string();
    BusStats stats;
    class Sink final : public RecordSink {
      public:
        Sink(BusStats& s, Totals* totals) : stats_(s), totals_(totals) {}
        void begin(const SessionInfo& session) override { stats_.begin(session); }
        void record(const Record& r) override { stats_.add(r); }
        void end(const Totals& t, const std::vector<std::string>&) override {
            stats_.finish();
            if (totals_ != nullptr) *totals_ = t;
        }

      private:
        BusStats& stats_;
        Totals* totals_;
    } sink(stats, totals);
    PipelineOptions options;
    options.bus = bus;
    EXPECT_TRUE(run_pipeline(**source, options, sink));
    return stats;
}

std::vector<std::string> lines_of(const std::string& text) {
    std::vector<std::string> lines;
    std::size_t from = 0;
    while (from < text.size()) {
        const std::size_t nl = text.find('\n', from);
        lines.push_back(text.substr(from, nl - from));
        if (nl == std::string::npos) break;
        from = nl + 1;
    }
    return lines;
}

// A strict little JSON checker (RFC 8259 grammar, no semantic checks), enough to prove
// that every JSONL line is one well-formed object.
class JsonChecker {
  public:
    explicit JsonChecker(std::string_view text) : s_(text) {}
    bool object_only() {
        ws();
        if (peek() != '{') return false;
        if (!value()) return false;
        ws();
        return i_ == s_.size();
    }

  private:
    [[nodiscard]] char peek() const { return i_ < s_.size() ? s_[i_] : '\0'; }
    void ws() {
        while (i_ < s_.size() && (s_[i_] == ' ' || s_[i_] == '\t' || s_[i_] == '\n')) ++i_;
    }
    bool literal(std::string_view word) {
        if (s_.substr(i_, word.size()) != word) return false;
        i_ += word.size();
        return true;
    }
    bool string() {
        if (peek() != '"') return false;
        for (++i_; i_ < s_.size(); ++i_) {
            const auto c = static_cast<unsigned char>(s_[i_]);
            if (c == '"') {
                ++i_;
                return true;
            }
            if (c < 0x20) return false;
            if (c == '\\') {
                ++i_;
                if (i_ >= s_.size()) return false;
                const char e = s_[i_];
                if (e == 'u') {
                    for (int k = 0; k < 4; ++k) {
                        ++i_;
                        if (i_ >= s_.size() || !std::isxdigit(static_cast<unsigned char>(s_[i_])))
                            return false;
                    }
                } else if (std::string_view("\"\\/bfnrt").find(e) == std::string_view::npos) {
                    return false;
                }
            }
        }
        return false;
    }
    bool digits() {
        const std::size_t from = i_;
        while (std::isdigit(static_cast<unsigned char>(peek()))) ++i_;
        return i_ > from;
    }
    bool number() {
        if (peek() == '-') ++i_;
        if (peek() == '0') {
            ++i_;
        } else if (!digits()) {
            return false;
        }
        if (peek() == '.') {
            ++i_;
            if (!digits()) return false;
        }
        if (peek() == 'e' || peek() == 'E') {
            ++i_;
            if (peek() == '+' || peek() == '-') ++i_;
            if (!digits()) return false;
        }
        return true;
    }
    bool value() {
        ws();
        bool ok = false;
        switch (peek()) {
            case '{':
                ok = members('}', true);
                break;
            case '[':
                ok = members(']', false);
                break;
            case '"':
                ok = string();
                break;
            case 't':
                ok = literal("true");
                break;
            case 'f':
                ok = literal("false");
                break;
            case 'n':
                ok = literal("null");
                break;
            default:
                ok = number();
        }
        ws();
        return ok;
    }
    bool members(char close, bool keyed) {
        ++i_;
        ws();
        if (peek() == close) {
            ++i_;
            return true;
        }
        while (true) {
            ws();
            if (keyed) {
                if (!string()) return false;
                ws();
                if (peek() != ':') return false;
                ++i_;
            }
            if (!value()) return false;
            if (peek() == ',') {
                ++i_;
                continue;
            }
            if (peek() != close) return false;
            ++i_;
            return true;
        }
    }

    std::string_view s_;
    std::size_t i_ = 0;
};

const Bytes kRead = with_crc({0x01, 0x03, 0x00, 0x00, 0x00, 0x02});
const Bytes kAnswer = with_crc({0x01, 0x03, 0x04, 0x00, 0x01, 0x00, 0x02});

// The i-th of up to 5,000 reads (kRead at `t`), answered after 4.000-8.999 ms in 1 µs
// steps: i * 7 % 5000 takes every value of 0-4999 once, so no two turnarounds are equal.
void add_read_answered_distinctly(BusStats& s, Nanos i, Nanos t) {
    s.add(make_record(Kind::request, kRead, t));
    s.add(make_record(Kind::response, kAnswer, t + 20 * kMs, 4 * kMs + (i * 7 % 5'000) * 1000));
}

// ---------------------------------------------------------------------------------------

// The percentile of `values` as DurationCounts gives it, the values added in the order
// given.
std::optional<Nanos> percentile_of(const std::vector<Nanos>& values, unsigned percent,
                                   std::size_t max_distinct = 1024) {
    DurationCounts counts(max_distinct);
    for (Nanos v : values) counts.add(v);
    counts.finish();
    return counts.percentile(percent);
}

// The test's own nearest rank of sorted values, straight from the definition:
// sorted[ceil(p/100 * n) - 1].
Nanos exact_rank(const std::vector<Nanos>& sorted, unsigned percent) {
    const auto n = static_cast<double>(sorted.size());
    const auto rank = static_cast<std::size_t>(std::ceil(percent / 100.0 * n - 1e-9));
    return sorted[std::max<std::size_t>(rank, 1) - 1];
}

TEST(StatsPercentile, NearestRankOf1To100) {
    std::vector<Nanos> v;
    for (Nanos i = 1; i <= 100; ++i) v.push_back(i);
    std::shuffle(v.begin(), v.end(), std::mt19937(7));
    EXPECT_EQ(percentile_of(v, 50), 50);
    EXPECT_EQ(percentile_of(v, 95), 95);
    EXPECT_EQ(percentile_of(v, 99), 99);
    EXPECT_EQ(percentile_of(v, 100), 100);
    EXPECT_EQ(percentile_of(v, 0), 1);
}

TEST(StatsPercentile, SmallSetsTakeTheNextRankUp) {
    EXPECT_FALSE(percentile_of({}, 50).has_value());
    EXPECT_EQ(percentile_of({7}, 50), 7);
    EXPECT_EQ(percentile_of({7}, 99), 7);
    // ceil(0.5 * 4) = 2nd, ceil(0.95 * 4) = 4th: never an interpolated 25.
    EXPECT_EQ(percentile_of({40, 10, 30, 20}, 50), 20);
    EXPECT_EQ(percentile_of({40, 10, 30, 20}, 95), 40);
    const std::vector<Nanos> ten{10, 9, 8, 7, 6, 5, 4, 3, 2, 1};
    EXPECT_EQ(percentile_of(ten, 95), 10);
    EXPECT_EQ(percentile_of(ten, 50), 5);
    // The rank rounds up, never to the nearest: ceil(0.41 * 10) = 5, ceil(0.4 * 3) = 2.
    EXPECT_EQ(percentile_of(ten, 41), 5);
    EXPECT_EQ(percentile_of({3, 1, 2}, 40), 2);
    // Repeated values count once each.
    EXPECT_EQ(percentile_of({5, 5, 5, 1}, 25), 1);
    EXPECT_EQ(percentile_of({5, 5, 5, 1}, 26), 5);
}

TEST(StatsPercentile, ExactWhileTheDistinctValuesFit) {
    // 200,000 turnarounds of a µs-stamped capture: 1,000 distinct values, in batches of
    // any order.
    std::mt19937 random(1);
    std::uniform_int_distribution<Nanos> micros(4'000, 4'999);
    std::vector<Nanos> values;
    for (int i = 0; i < 200'000; ++i) values.push_back(micros(random) * 1000);
    DurationCounts counts(1024);
    for (Nanos v : values) counts.add(v);
    counts.finish();
    EXPECT_EQ(counts.size(), values.size());
    EXPECT_EQ(counts.bin_width(), 0);
    EXPECT_EQ(counts.held(), 1000U);
    std::sort(values.begin(), values.end());
    for (unsigned p = 0; p <= 100; ++p) EXPECT_EQ(counts.percentile(p), exact_rank(values, p)) << p;
}

TEST(StatsPercentile, BeyondTheBoundBinnedAtMostOneBinLowInBoundedMemory) {
    // A nanosecond-stamped live line: every value distinct, 0-50 ms, a few negative ones
    // (a clock stepping back), a single far outlier.
    std::mt19937 random(2);
    std::uniform_int_distribution<Nanos> nanos(-2'000'000, 50'000'000);
    std::vector<Nanos> values;
    for (int i = 0; i < 300'000; ++i) values.push_back(nanos(random));
    values.push_back(3'600 * kNanosPerSecond);
    DurationCounts counts(1024);
    for (Nanos v : values) counts.add(v);
    counts.finish();
    EXPECT_EQ(counts.size(), values.size());
    EXPECT_LE(counts.held(), 1024U);
    // 52 ms in at most 1,024 bins: 64 µs (812 bins; 32 µs would need 1,625).
    EXPECT_EQ(counts.bin_width(), 64'000);
    std::vector<Nanos> sorted = values;
    std::sort(sorted.begin(), sorted.end());
    for (unsigned p = 0; p < 100; ++p) {
        const Nanos exact = exact_rank(sorted, p);
        const Nanos binned = *counts.percentile(p);
        EXPECT_LE(binned, exact) << p;
        EXPECT_LT(exact - binned, counts.bin_width()) << p;
        EXPECT_TRUE(std::binary_search(sorted.begin(), sorted.end(), binned)) << p;
    }
    EXPECT_EQ(counts.percentile(100), 3'600 * kNanosPerSecond);  // the maximum stays exact
}

TEST(StatsPercentile, MergedCountsKeepTheWiderBins) {
    std::mt19937 random(3);
    std::uniform_int_distribution<Nanos> wide(0, 900'000'000);
    std::uniform_int_distribution<Nanos> narrow(10'000, 10'099);
    DurationCounts a(256);
    DurationCounts b(256);
    DurationCounts pooled(1024);
    std::vector<Nanos> values;
    for (int i = 0; i < 50'000; ++i) {
        const Nanos x = wide(random);
        const Nanos y = narrow(random) * 1000;
        a.add(x);
        b.add(y);
        values.insert(values.end(), {x, y});
    }
    a.finish();
    b.finish();
    EXPECT_EQ(b.bin_width(), 0);  // 100 distinct values
    pooled.merge(a);
    pooled.merge(b);
    pooled.finish();
    EXPECT_EQ(pooled.size(), values.size());
    EXPECT_GE(pooled.bin_width(), a.bin_width());
    EXPECT_LE(pooled.held(), 1024U);
    std::sort(values.begin(), values.end());
    for (unsigned p : {1U, 25U, 50U, 75U, 95U, 99U}) {
        const Nanos exact = exact_rank(values, p);
        const Nanos binned = *pooled.percentile(p);
        EXPECT_LE(binned, exact) << p;
        EXPECT_LT(exact - binned, pooled.bin_width()) << p;
    }
    EXPECT_EQ(pooled.percentile(100), *std::max_element(values.begin(), values.end()));
}

TEST(StatsPercentile, ALowerLimitWidensTheBinsAndGivesTheRoomBack) {
    std::mt19937 random(4);
    std::uniform_int_distribution<Nanos> micros(4'000, 4'999);
    std::vector<Nanos> values;
    for (int i = 0; i < 20'000; ++i) values.push_back(micros(random) * 1000);
    DurationCounts counts;
    for (Nanos v : values) counts.add(v);
    counts.finish();
    ASSERT_EQ(counts.held(), 1000U);  // exact so far
    counts.limit(64);
    EXPECT_LE(counts.held(), 64U);
    EXPECT_EQ(counts.bin_width(), 16'000);  // 1,000 µs: 16 µs makes 63 bins, 8 µs 125
    for (int i = 0; i < 5'000; ++i) counts.add(micros(random) * 1000 + 2'000'000);
    counts.finish();
    EXPECT_LE(counts.held(), 64U);  // the new values keep to the new limit too
    EXPECT_EQ(counts.size(), 25'000U);
}

// A row of its own for each of `rows` slave/function pairs, each answered `answers`
// times with distinct turnarounds.
BusStats answered_rows(unsigned rows, int answers) {
    BusStats s;
    for (unsigned r = 0; r < rows; ++r) {
        const auto slave = static_cast<std::uint8_t>(1 + r / 8);
        const auto function = static_cast<std::uint8_t>(1 + r % 8);
        Record answer = make_record(Kind::response, with_crc({slave, function, 0x00}));
        for (int i = 0; i < answers; ++i) {
            answer.latency = (2'000 + 7 * i) * 1000;
            s.add(answer);
        }
    }
    s.finish();
    return s;
}

TEST(StatsTurnaround, EachRowHasTheFullBoundOnATypicalBus) {
    const BusStats s = answered_rows(64, 1'500);
    EXPECT_EQ(s.bins_each(), DurationCounts::kMaxDistinct);
    for (const auto& [key, row] : s.functions()) {
        EXPECT_EQ(row.turnarounds.bin_width(), 16'000);  // 10.5 ms: 8 µs would be 1,313 bins
    }
}

TEST(StatsTurnaround, ALargeBusSharesTheBinsAmongItsRows) {
    // 247 slaves x 8 functions would be 44 MiB of bins at 1,024 each; 1,100 rows here, so
    // each may hold 256 (2^19 / 1,100 is 476), the first rows limited once the later came.
    const BusStats s = answered_rows(1'100, 300);
    EXPECT_EQ(s.bins_each(), 256U);
    std::size_t bins = 0;
    for (const auto& [key, row] : s.functions()) {
        EXPECT_EQ(row.turnarounds.size(), 300U);
        EXPECT_LE(row.turnarounds.held(), 256U);
        EXPECT_EQ(row.turnarounds.bin_width(), 16'000);         // 2.1 ms: 8 µs would be 263 bins
        EXPECT_EQ(row.turnarounds.percentile(99), 4'065'000);   // exact 4.072: in 4.064-4.080
        EXPECT_EQ(row.turnarounds.percentile(100), 4'093'000);  // the maximum stays exact
        bins += row.turnarounds.held();
    }
    EXPECT_LE(bins, BusStats::kBinBudget);
    EXPECT_NE(render_stats(s, StatsFormat::text)
                  .find("note: ~ marks a percentile counted in bins (more than 256 distinct"),
              std::string::npos);
}

TEST(StatsTurnaround, TheBenchmarksLargestBusKeepsToItsShare) {
    // rtuscope_bench_gen --all-slaves 8: every slave 1-247 asked functions 1-8 in turn.
    bench::TrafficOptions options;
    // Enough rounds for more than 16 turnarounds a row and cycles a poll: those share.
    options.frames = 100'000;
    options.all_slaves_functions = 8;
    const BusStats s = stats_of(bench::traffic_in_memory(options).capture, InputFormat::capture);
    EXPECT_EQ(s.bins_each(), 128U);  // 2^19 among ~1,976 rows and as many polls
    for (unsigned slave = 1; slave <= 247; ++slave) {
        for (unsigned function = 1; function <= 8; ++function) {
            const auto row = s.functions().find(
                {static_cast<std::uint8_t>(slave), static_cast<std::uint8_t>(function)});
            ASSERT_NE(row, s.functions().end()) << slave << " " << function;
            // Every exception by code; FC07's to a request of a read's length answer none.
            EXPECT_GE(row->second.exception_codes.at(0x01), 5U) << slave << " " << function;
            EXPECT_LE(row->second.turnarounds.held(), 128U);
            // Each poll has its cycle; FC07 has none, its requests carrying data it has not.
            if (function == 7) continue;
            const auto* poll = s.main_poll(BusStats::Key{row->first});
            ASSERT_NE(poll, nullptr) << slave << " " << function;
            EXPECT_GE(poll->second.cycles.size(), 1U) << slave << " " << function;
        }
    }
}

TEST(StatsCounts, ExceptionCodesListedUpToTheBoundAndStillCountedBeyond) {
    // 40 slaves answering every code 0-255: 10,240 slave/function/code triples.
    BusStats s;
    for (unsigned slave = 1; slave <= 40; ++slave) {
        for (unsigned code = 0; code < 256; ++code) {
            s.add(make_record(Kind::exception, with_crc({static_cast<std::uint8_t>(slave), 0x83,
                                                         static_cast<std::uint8_t>(code)})));
        }
    }
    s.add(make_record(Kind::exception, with_crc({1, 0x83, 0x02})));  // a listed triple again
    s.finish();
    std::size_t listed = 0;
    for (const auto& [key, row] : s.functions()) {
        EXPECT_EQ(row.exceptions, key.first == 1 ? 257U : 256U);  // every one in its row
        listed += row.exception_codes.size();
    }
    EXPECT_EQ(listed, BusStats::kMaxExceptionCodes);
    EXPECT_EQ(s.unlisted_exceptions(), 10'240U - BusStats::kMaxExceptionCodes);
    EXPECT_EQ(s.functions().at({1, 3}).exception_codes.at(0x02), 2U);
    EXPECT_EQ(s.functions().count({33, 3}), 1U);
    EXPECT_TRUE(s.functions().at({33, 3}).exception_codes.empty());  // 32 x 256 = 8,192 before
    EXPECT_NE(render_stats(s, StatsFormat::text)
                  .find("note: 2048 exceptions not listed by code, beyond 8192 distinct "
                        "slave/function/code (they still count in the rows)\n"),
              std::string::npos);
    EXPECT_NE(render_stats(s, StatsFormat::jsonl).find("\"unlisted_exceptions\":2048,"),
              std::string::npos);
}

TEST(StatsCycle, ForgottenPollsGiveTheirShareOfTheBinsBack) {
    // 100,000 distinct requests, each sent twice (one cycle each): at most kMaxPolls polls
    // are kept at a time, whose 16 bins each leave the full bound for the others. Had the
    // forgotten polls kept their place, 100,000 sets of 16 would leave every set 16.
    BusStats s;
    Nanos t = 0;
    for (unsigned i = 0; i < 100'000; ++i) {
        const auto high = static_cast<std::uint8_t>(i >> 8);
        const auto low = static_cast<std::uint8_t>(i);
        const Record request = make_record(
            Kind::request,
            with_crc({static_cast<std::uint8_t>(1 + i % 200), 0x06, high, low, 0, 1}), t);
        s.add(request);
        Record again = request;
        again.frame.start = t + 5 * kMs;
        s.add(again);
        t += 10 * kMs;
    }
    s.finish();
    EXPECT_LE(s.polls().size(), BusStats::kMaxPolls);
    EXPECT_GT(s.polls().size(), BusStats::kMaxPolls / 2);
    EXPECT_EQ(s.bins_each(), DurationCounts::kMaxDistinct);
}

TEST(StatsCycle, PollsOfFewCyclesLeaveTheBinsToTheRest) {
    // One poll answered 5,000 times, its turnarounds all different (as in
    // BinnedPercentilesAreMarkedInEveryFormat), among 3,000 other requests sent twice each:
    // their one cycle each needs one bin, so the busy row keeps the full bound. Shared by
    // the number of sets with values, 3,002 of them, it would have had 128 bins.
    BusStats s;
    for (Nanos i = 0; i < 5'000; ++i) {
        const Nanos t = i * 100 * kMs;
        add_read_answered_distinctly(s, i, t);
        if (i < 3'000) {
            const Bytes other = with_crc({0x02, 0x06, static_cast<std::uint8_t>(i >> 8),
                                          static_cast<std::uint8_t>(i), 0, 1});
            s.add(make_record(Kind::request, other, t + 30 * kMs));
            s.add(make_record(Kind::request, other, t + 60 * kMs));
        }
    }
    s.finish();
    EXPECT_EQ(s.polls().size(), 3'001U);
    EXPECT_EQ(s.bins_each(), DurationCounts::kMaxDistinct);
    const FunctionStats& row = s.functions().at({1, 3});
    EXPECT_EQ(row.turnarounds.bin_width(), 8'000);  // 5,000 µs in 625 bins of 8 µs
    EXPECT_EQ(row.turnarounds.percentile(50), 6'496'000);
}

TEST(StatsCounts, PerSlaveAndFunction) {
    BusStats s;
    s.add(make_record(Kind::request, kRead));
    s.add(make_record(Kind::response, kAnswer));
    s.add(with_note(make_record(Kind::request, kRead), note_id::no_answer));
    // Exceptions count under their function, per code.
    s.add(make_record(Kind::request, kRead));
    s.add(make_record(Kind::exception, with_crc({0x01, 0x83, 0x02})));
    s.add(make_record(Kind::request, kRead));
    s.add(make_record(Kind::exception, with_crc({0x01, 0x83, 0x02})));
    s.add(with_note(make_record(Kind::exception, with_crc({0x01, 0x83, 0x04})),
                    note_id::unsolicited));
    // Another slave: a swapped CRC and a bad one, a broadcast, noise.
    Bytes swapped = with_crc({0x02, 0x04, 0x00, 0x10, 0x00, 0x01});
    std::swap(swapped[6], swapped[7]);
    s.add(make_record(Kind::request, swapped));
    s.add(make_record(Kind::invalid, {0x02, 0x04, 0x02, 0x00, 0x05, 0x00, 0x00}));
    s.add(make_record(Kind::broadcast, with_crc({0x00, 0x06, 0x00, 0x01, 0x00, 0x03})));
    s.add(make_record(Kind::noise, {0xFF, 0xFE, 0x00}));
    s.add(make_record(Kind::invalid, {0x05}));  // cut short: no function code
    s.finish();

    const auto& rows = s.functions();
    ASSERT_EQ(rows.size(), 3U);
    const FunctionStats& a = rows.at({1, 3});
    EXPECT_EQ(a.requests, 4U);
    EXPECT_EQ(a.answers, 1U);
    EXPECT_EQ(a.exceptions, 2U);  // the unsolicited one answers no request: in `unsolicited`
    EXPECT_EQ(a.exception_codes.at(2), 2U);
    EXPECT_EQ(a.exception_codes.at(4), 1U);
    EXPECT_EQ(a.no_answer, 1U);
    EXPECT_EQ(a.unsolicited, 1U);
    EXPECT_EQ(a.crc_errors, 0U);
    EXPECT_TRUE(a.turnarounds.empty());  // untimed

    const FunctionStats& b = rows.at({2, 4});
    EXPECT_EQ(b.requests, 1U);
    EXPECT_EQ(b.crc_errors, 2U);
    EXPECT_EQ(rows.at({0, 6}).broadcasts, 1U);

    EXPECT_EQ(s.all().requests, 5U);
    EXPECT_EQ(s.all().crc_errors, 2U);
    EXPECT_EQ(s.all().exception_codes.at(2), 2U);
    EXPECT_EQ(s.bus().frames, 12U);
    EXPECT_EQ(s.bus().noise_runs, 1U);
    EXPECT_EQ(s.bus().noise_bytes, 3U);
    EXPECT_EQ(s.bus().invalid, 2U);
    EXPECT_FALSE(s.timed());
    EXPECT_FALSE(s.utilisation().has_value());
}

TEST(StatsTurnaround, PercentilesOfAnswers1To100Ms) {
    std::vector<Nanos> latencies;
    for (Nanos i = 1; i <= 100; ++i) latencies.push_back(i * kMs);
    std::mt19937 shuffle(42);
    std::shuffle(latencies.begin(), latencies.end(), shuffle);
    BusStats s;
    Nanos t = 0;
    for (Nanos l : latencies) {
        s.add(make_record(Kind::request, kRead, t));
        s.add(make_record(Kind::response, kAnswer, t + 10 * kMs, l));
        t += 200 * kMs;
    }
    s.add(make_record(Kind::response, kAnswer));  // unknown latency: not measured
    s.finish();

    const std::string csv = render_stats(s, StatsFormat::csv);
    EXPECT_NE(csv.find("\n1,3,100,101,0,0,0,0,0,100,50.000,95.000,99.000,100.000,200.000,200.000,"
                       "0.000,0.000,0\n"),
              std::string::npos)
        << csv;
    const FunctionStats& row = s.functions().at({1, 3});
    EXPECT_EQ(row.turnarounds.size(), 100U);
    EXPECT_EQ(row.turnarounds.percentile(50), 50 * kMs);
    EXPECT_EQ(row.turnarounds.percentile(99), 99 * kMs);
}

TEST(StatsCycle, EachRowsPollIsTheMostFrequentOfItsOwnSlaveAndFunction) {
    // Polls of neighbouring keys in the map, some more frequent than the row's own: slave
    // 1 FC01 and FC04 around slave 1 FC03, slave 2 FC03 after it.
    const Bytes coils = with_crc({0x01, 0x01, 0x00, 0x00, 0x00, 0x08});
    const Bytes low = with_crc({0x01, 0x03, 0x00, 0x00, 0x00, 0x01});
    const Bytes high = with_crc({0x01, 0x03, 0xFF, 0xFF, 0x00, 0x01});
    const Bytes inputs = with_crc({0x01, 0x04, 0x00, 0x00, 0x00, 0x01});
    const Bytes other_slave = with_crc({0x02, 0x03, 0x00, 0x00, 0x00, 0x01});
    BusStats s;
    Nanos t = 0;
    auto poll = [&](const Bytes& request, int times) {
        for (int i = 0; i < times; ++i) s.add(make_record(Kind::request, request, (t += 10) * kMs));
    };
    poll(coils, 5);
    poll(low, 2);
    poll(high, 3);
    poll(inputs, 6);
    poll(other_slave, 7);
    s.finish();

    const auto* fc03 = s.main_poll(BusStats::Key{1, 3});
    ASSERT_NE(fc03, nullptr);
    EXPECT_EQ(fc03->first.data, (std::array<std::uint8_t, 4>{0xFF, 0xFF, 0x00, 0x01}));
    EXPECT_EQ(fc03->second.requests, 3U);
    EXPECT_EQ(s.main_poll(BusStats::Key{1, 1})->second.requests, 5U);
    EXPECT_EQ(s.main_poll(BusStats::Key{1, 4})->second.requests, 6U);
    EXPECT_EQ(s.main_poll(BusStats::Key{2, 3})->second.requests, 7U);
    EXPECT_EQ(s.main_poll(BusStats::Key{2, 4}), nullptr);
    EXPECT_EQ(s.main_poll(BusStats::Key{0, 3}), nullptr);
    EXPECT_EQ(s.main_poll(std::nullopt)->first.slave, 2U);
}

TEST(StatsCycle, MedianAndMaxOfTheMostFrequentPoll) {
    const Bytes other = with_crc({0x01, 0x03, 0x00, 0x06, 0x00, 0x02});
    BusStats s;
    // 0x0000 x2 at 0, 100, 200, 400 ms: cycles 100, 100, 200. 0x0006 x2 twice, 50 apart.
    for (Nanos t : {0, 100, 200, 400}) s.add(make_record(Kind::request, kRead, t * kMs));
    for (Nanos t : {500, 550}) s.add(make_record(Kind::request, other, t * kMs));
    s.finish();

    const auto* main = s.main_poll(std::nullopt);
    ASSERT_NE(main, nullptr);
    EXPECT_EQ(main->first.data, (std::array<std::uint8_t, 4>{0, 0, 0, 2}));
    EXPECT_EQ(main->second.requests, 4U);
    EXPECT_EQ(main->second.cycles.percentile(50), 100 * kMs);
    EXPECT_EQ(main->second.cycles.percentile(100), 200 * kMs);
    EXPECT_EQ(s.polls().size(), 2U);
    EXPECT_EQ(s.polls().rbegin()->second.cycles.size(), 1U);
    EXPECT_EQ(s.polls().rbegin()->second.cycles.percentile(50), 50 * kMs);

    const std::string text = render_stats(s, StatsFormat::text);
    EXPECT_NE(text.find("poll cycle: 100.00 ms median, 200.00 ms max (slave 1 function 03 "
                        "0x0000 x2, 4 requests)"),
              std::string::npos)
        << text;
}

TEST(StatsCycle, AFullPollTableForgetsTheRarestRequests) {
    // A master polling three registers, every 10, 100 and 1,000 ms, and writing a new
    // value every 10 ms: 20,000 distinct writes come and go, the three polls stay.
    const Bytes fast = with_crc({0x01, 0x03, 0x00, 0x10, 0x00, 0x01});
    const Bytes medium = with_crc({0x01, 0x03, 0x00, 0x20, 0x00, 0x01});
    const Bytes slow = with_crc({0x01, 0x04, 0x00, 0x30, 0x00, 0x01});
    BusStats s;
    for (int tick = 0; tick < 20'000; ++tick) {
        const Nanos t = tick * 10 * kMs;
        s.add(make_record(Kind::request, fast, t));
        if (tick % 10 == 0) s.add(make_record(Kind::request, medium, t + kMs));
        if (tick % 100 == 0) s.add(make_record(Kind::request, slow, t + 2 * kMs));
        const auto low = static_cast<std::uint8_t>(tick);
        const auto high = static_cast<std::uint8_t>(tick >> 8);
        s.add(
            make_record(Kind::request, with_crc({0x02, 0x06, 0x00, 0x01, high, low}), t + 5 * kMs));
    }
    s.finish();
    EXPECT_LE(s.polls().size(), BusStats::kMaxPolls);
    EXPECT_EQ(s.polls().size() + s.forgotten_polls(), 20'003U);  // every poll counted once
    const std::pair<Bytes, Nanos> expected[] = {
        {fast, 10 * kMs}, {medium, 100 * kMs}, {slow, 1000 * kMs}};
    for (const auto& [request, cycle] : expected) {
        PollKey key{request[0], request[1], {request[2], request[3], request[4], request[5]}, 4};
        ASSERT_EQ(s.polls().count(key), 1U) << cycle;
        const PollStats& poll = s.polls().at(key);
        EXPECT_EQ(poll.requests * static_cast<std::uint64_t>(cycle), 200'000U * kMs) << cycle;
        EXPECT_EQ(poll.cycles.size(), poll.requests - 1) << cycle;
        EXPECT_EQ(poll.cycles.percentile(50), cycle);
    }
    EXPECT_EQ(s.main_poll(std::nullopt)->second.requests, 20'000U);
    EXPECT_EQ(s.functions().at({2, 6}).requests, 20'000U);  // the row still counts them all

    const std::string note = fmt::format(
        "note: {} rare polls forgotten to keep to {} distinct requests (their requests still "
        "count in the rows)\n",
        s.forgotten_polls(), BusStats::kMaxPolls);
    EXPECT_NE(render_stats(s, StatsFormat::text).find(note), std::string::npos);
    EXPECT_NE(render_stats(s, StatsFormat::jsonl)
                  .find(fmt::format("\"forgotten_polls\":{},", s.forgotten_polls())),
              std::string::npos);
}

TEST(StatsCycle, APollListLongerThanTheTableKeepsMostOfItsCycles) {
    // A master polling 1.5 x kMaxPolls registers in turn, one a millisecond, five times
    // round: no poll comes again before the table is full. Had the polls seen once been
    // ranked by their own short time, the newest first, each would be forgotten before
    // it came again and the bus would show no cycle at all.
    constexpr std::size_t kList = BusStats::kMaxPolls + BusStats::kMaxPolls / 2;
    constexpr Nanos kCycle = static_cast<Nanos>(kList) * kMs;
    BusStats s;
    Nanos t = 0;
    for (int round = 0; round < 5; ++round) {
        for (std::size_t i = 0; i < kList; ++i, t += kMs) {
            const auto slave = static_cast<std::uint8_t>(1 + i % 247);
            const auto address = static_cast<std::uint8_t>(i / 247);
            s.add(make_record(Kind::request, with_crc({slave, 0x03, 0, address, 0, 1}), t));
        }
    }
    s.finish();
    EXPECT_LE(s.polls().size(), BusStats::kMaxPolls);
    std::size_t with_every_cycle = 0;
    for (const auto& [key, poll] : s.polls()) {
        if (poll.requests != 5) continue;
        ++with_every_cycle;
        EXPECT_EQ(poll.cycles.percentile(50), kCycle);
        EXPECT_EQ(poll.cycles.percentile(100), kCycle);
    }
    EXPECT_GE(with_every_cycle, BusStats::kMaxPolls / 2);
    const auto* main = s.main_poll(std::nullopt);
    ASSERT_NE(main, nullptr);
    EXPECT_EQ(main->second.cycles.percentile(50), kCycle);
    EXPECT_EQ(render_stats(s, StatsFormat::text).find("no request repeated"), std::string::npos);
}

TEST(StatsTurnaround, BinnedPercentilesAreMarkedInEveryFormat) {
    // 5,000 answers whose turnarounds are all different.
    BusStats s;
    for (Nanos i = 0; i < 5'000; ++i) add_read_answered_distinctly(s, i, i * 100 * kMs);
    s.finish();
    const FunctionStats& row = s.functions().at({1, 3});
    EXPECT_EQ(row.turnarounds.bin_width(), 8'000);  // 5,000 µs in 625 bins of 8 µs
    // The 2,500th value, 6.499 ms, lies in the bin 6.496-6.503 ms, and 6.496 came.
    EXPECT_EQ(row.turnarounds.percentile(50), 6'496'000);
    EXPECT_EQ(row.turnarounds.percentile(100), 8'999'000);

    const std::string text = render_stats(s, StatsFormat::text);
    EXPECT_NE(text.find("note: ~ marks a percentile counted in bins (more than 1024 distinct "
                        "turnarounds in a row or cycles of a poll): up to one bin below the "
                        "exact figure, here at most 0.008 ms and 0.1 % of it\n"),
              std::string::npos)
        << text;
    EXPECT_NE(text.find("5000  ~6.50  ~8.74  ~8.94  9.00  100.00   100.00\n"), std::string::npos)
        << text;
    const std::string csv = render_stats(s, StatsFormat::csv);
    EXPECT_NE(csv.find("\n1,3,5000,5000,0,0,0,0,0,5000,6.496,8.744,8.944,8.999,100.000,100.000,"
                       "0.008,0.000,0\n"),
              std::string::npos)
        << csv;
    const std::string jsonl = render_stats(s, StatsFormat::jsonl);
    EXPECT_NE(jsonl.find("\"turnaround_bin_ms\":0.008,\"cycle_bin_ms\":0.000}"), std::string::npos)
        << jsonl;
}

// Two transactions on 9600 8N1, one chunk per frame (time = last byte): the first request
// starts 8 characters before 0.010 s, the last answer ends at 0.130 s.
const char* const kTimedCapture =
    "# rtuscope capture v1\n"
    "# serial 9600 8N1\n"
    "0.010000 01 03 00 00 00 02 C4 0B\n"
    "0.030000 01 03 04 00 01 00 02 2A 32\n"
    "0.110000 01 03 00 00 00 02 C4 0B\n"
    "0.130000 01 03 04 00 01 00 02 2A 32\n";

TEST(StatsPipeline, UtilisationTurnaroundAndCycleOfATimedCapture) {
    const BusStats s = stats_of(kTimedCapture, InputFormat::capture);
    const Nanos c = LineSettings{}.char_time();
    ASSERT_TRUE(s.timed());
    EXPECT_EQ(*s.duration(), 130 * kMs - (10 * kMs - 8 * c));
    EXPECT_EQ(s.bus().bytes, 34U);
    ASSERT_TRUE(s.utilisation().has_value());
    // 34 characters of 1.0417 ms in 128.33 ms
    EXPECT_NEAR(*s.utilisation(), 27.597, 0.01);

    const FunctionStats& row = s.functions().at({1, 3});
    EXPECT_EQ(row.requests, 2U);
    EXPECT_EQ(row.answers, 2U);
    // End of request (0.010) to start of answer (0.030 - 9 characters)
    ASSERT_EQ(row.turnarounds.size(), 2U);
    EXPECT_EQ(row.turnarounds.percentile(0), 20 * kMs - 9 * c);
    const auto* poll = s.main_poll(BusStats::Key{1, 3});
    ASSERT_NE(poll, nullptr);
    ASSERT_EQ(poll->second.cycles.size(), 1U);
    EXPECT_EQ(poll->second.cycles.percentile(50), 100 * kMs);

    const std::string text = render_stats(s, StatsFormat::text);
    EXPECT_NE(text.find("utilisation 27.6 %"), std::string::npos) << text;
    EXPECT_EQ(text.find("no timing"), std::string::npos) << text;
}

TEST(StatsPipeline, UntimedInputSaysSoAndLeavesTimesUnknown) {
    const BusStats s =
        stats_of("01 03 00 00 00 02 C4 0B\n01 03 04 00 01 00 02 2A 32\n", InputFormat::hex);
    EXPECT_FALSE(s.timed());
    EXPECT_FALSE(s.duration().has_value());
    EXPECT_EQ(s.functions().at({1, 3}).answers, 1U);

    const std::string text = render_stats(s, StatsFormat::text);
    EXPECT_NE(text.find("no timing: turnaround, utilisation and cycle unknown\n"),
              std::string::npos)
        << text;
    EXPECT_EQ(text.find("utilisation 0"), std::string::npos) << text;
    const std::string csv = render_stats(s, StatsFormat::csv);
    EXPECT_NE(csv.find("\n1,3,1,1,0,0,0,0,0,0,,,,,,,,,0\n"), std::string::npos) << csv;
    const std::string jsonl = render_stats(s, StatsFormat::jsonl);
    EXPECT_NE(jsonl.find("\"timed\":false,\"duration_s\":null"), std::string::npos) << jsonl;
    EXPECT_NE(jsonl.find("\"utilisation_pct\":null"), std::string::npos) << jsonl;
    EXPECT_NE(jsonl.find("\"turnaround_p50_ms\":null"), std::string::npos) << jsonl;
}

TEST(StatsCsv, HeaderRowsAndTheAllRow) {
    const BusStats s = stats_of(kTimedCapture, InputFormat::capture);
    const std::vector<std::string> lines = lines_of(render_stats(s, StatsFormat::csv));
    ASSERT_EQ(lines.size(), 3U);
    EXPECT_EQ(
        lines[0],
        "slave,function,requests,answers,exceptions,crc_errors,no_answer,broadcasts,"
        "unsolicited,turnarounds,turnaround_p50_ms,turnaround_p95_ms,turnaround_p99_ms,"
        "turnaround_max_ms,cycle_median_ms,cycle_max_ms,turnaround_bin_ms,cycle_bin_ms,broken");
    // turnaround 20 ms - 9 characters = 10.625 ms
    EXPECT_EQ(lines[1],
              "1,3,2,2,0,0,0,0,0,2,10.625,10.625,10.625,10.625,100.000,100.000,0.000,0.000,0");
    EXPECT_EQ(lines[2],
              "all,all,2,2,0,0,0,0,0,2,10.625,10.625,10.625,10.625,100.000,100.000,0.000,0.000,0");
}

TEST(StatsOutput, AFullTableIsWrittenInPiecesNeverHeldWhole) {
    // Noise in a long enough capture reaches every row (256 slaves x 128 functions): the
    // table is megabytes, handed on in pieces of about 64 KiB as it is made.
    BusStats s;
    for (unsigned slave = 0; slave < 256; ++slave) {
        for (unsigned function = 0; function < 128; ++function) {
            const Bytes frame = with_crc({static_cast<std::uint8_t>(slave),
                                          static_cast<std::uint8_t>(function), 0x00, 0x01});
            s.add(make_record(slave == 0 ? Kind::broadcast : Kind::request, frame));
        }
    }
    s.finish();
    ASSERT_EQ(s.functions().size(), 256U * 128U);
    for (StatsFormat format : {StatsFormat::text, StatsFormat::csv, StatsFormat::jsonl}) {
        std::string whole;
        std::size_t pieces = 0;
        std::size_t largest = 0;
        write_stats(
            s, format, {},
            [&](std::string_view piece) {
                whole += piece;
                ++pieces;
                largest = std::max(largest, piece.size());
            },
            0);
        EXPECT_GT(whole.size(), std::size_t{10} << 16);  // ten pieces at least
        EXPECT_GT(pieces, whole.size() / (std::size_t{66} << 10));
        EXPECT_LT(largest, std::size_t{66} << 10);  // 64 KiB and the line that passed it
        EXPECT_EQ(whole, render_stats(s, format, {}, 0));
        EXPECT_EQ(std::count(whole.begin(), whole.end(), '\n'),
                  format == StatsFormat::text  ? 32'768 + 9    // rows, all, header, 6 above
                  : format == StatsFormat::csv ? 32'768 + 2    // rows, all, header
                                               : 32'768 + 1);  // rows, the bus line
    }
}

// Slave s (1..30) asked s times: rows of 1 to 30 requests.
BusStats thirty_slaves() {
    BusStats s;
    for (unsigned slave = 1; slave <= 30; ++slave) {
        for (unsigned i = 0; i < slave; ++i) {
            s.add(make_record(Kind::request, with_crc({static_cast<std::uint8_t>(slave), 0x03,
                                                       0x00, 0x00, 0x00, 0x01})));
        }
    }
    s.finish();
    return s;
}

bool lists_slave(const std::string& text, unsigned slave) {
    return text.find(fmt::format("\n{:>7}  03  Read Holding Registers", slave)) !=
           std::string::npos;
}

TEST(StatsText, ListsTheBusiestRowsAndCountsTheRest) {
    const BusStats s = thirty_slaves();
    const std::string text = render_stats(s, StatsFormat::text);
    for (unsigned slave = 11; slave <= 30; ++slave) EXPECT_TRUE(lists_slave(text, slave)) << slave;
    for (unsigned slave = 1; slave <= 10; ++slave) EXPECT_FALSE(lists_slave(text, slave)) << slave;
    // The ten left out hold 1 + 2 + ... + 10 requests; the all row counts all 465.
    EXPECT_NE(text.find("  ... 10 more rows with 55 frames (--top 0 lists them)\n"),
              std::string::npos)
        << text;
    EXPECT_NE(text.find("    all                              465"), std::string::npos) << text;

    const std::string three = render_stats(s, StatsFormat::text, {}, 3);
    EXPECT_TRUE(lists_slave(three, 28) && lists_slave(three, 29) && lists_slave(three, 30));
    EXPECT_FALSE(lists_slave(three, 27)) << three;
    EXPECT_NE(three.find("  ... 27 more rows with 378 frames"), std::string::npos) << three;
}

TEST(StatsText, TopZeroListsEveryRowAndCsvAlwaysDoes) {
    const BusStats s = thirty_slaves();
    const std::string text = render_stats(s, StatsFormat::text, {}, 0);
    for (unsigned slave = 1; slave <= 30; ++slave) EXPECT_TRUE(lists_slave(text, slave)) << slave;
    EXPECT_EQ(text.find("more rows"), std::string::npos) << text;
    const std::vector<std::string> csv = lines_of(render_stats(s, StatsFormat::csv, {}, 3));
    EXPECT_EQ(csv.size(), 1U + 30U + 1U);  // header, rows, all
}

TEST(StatsText, GarbledInvalidFramesMakeOneLineNotRows) {
    BusStats s;
    s.add(make_record(Kind::request, with_crc({0x01, 0x03, 0x00, 0x00, 0x00, 0x01})));
    // Bad CRCs that no pairing took for a request or an answer: their address and function
    // are whatever the corruption left.
    for (const std::uint8_t slave : {std::uint8_t{77}, std::uint8_t{78}, std::uint8_t{200}}) {
        Record r = make_record(Kind::invalid, {slave, 0x55, 0x12, 0x34, 0x00, 0x00});
        ASSERT_EQ(r.frame.crc.status, CrcStatus::bad);
        s.add(r);
    }
    s.finish();
    const std::string text = render_stats(s, StatsFormat::text);
    EXPECT_FALSE(lists_slave(text, 77));
    EXPECT_EQ(text.find("\n     77  55"), std::string::npos) << text;
    EXPECT_NE(text.find("  invalid frames that are no bus traffic (their address or function "
                        "code garbled): 3 CRC errors under 3 slaves and functions, in the all "
                        "row\n"),
              std::string::npos)
        << text;
    EXPECT_NE(text.find("\n      1  03  Read Holding Registers"), std::string::npos) << text;
    // CSV keeps their rows.
    EXPECT_NE(render_stats(s, StatsFormat::csv).find("\n77,85,"), std::string::npos);
}

TEST(StatsText, IrregularRepeatsHaveNoCycle) {
    const Bytes write = with_crc({0x01, 0x06, 0x00, 0x10, 0x00, 0x01});
    BusStats s;
    // A poll every 100 ms, and a write sent at 0, 10, 20 ms and then 5 s later.
    for (Nanos t = 0; t < 2000; t += 100) s.add(make_record(Kind::request, kRead, t * kMs));
    for (Nanos t : {0, 10, 20, 30, 5000}) s.add(make_record(Kind::request, write, t * kMs));
    s.finish();
    const std::string text = render_stats(s, StatsFormat::text);
    EXPECT_NE(text.find("      1  03  0x0000 x2        20        100.00     100.00\n"),
              std::string::npos)
        << text;
    EXPECT_EQ(text.find("00 10 00 01"), std::string::npos) << text;
    EXPECT_NE(text.find("  1 request repeats irregularly"), std::string::npos) << text;
    EXPECT_NE(text.find("irregular        -\n"), std::string::npos) << text;  // the 06 row
}

TEST(StatsJsonl, EveryLineIsOneObjectWithTheKeys) {
    BusStats s = stats_of(kTimedCapture, InputFormat::capture);
    s.add(make_record(Kind::exception, with_crc({0x02, 0x84, 0x02})));
    s.finish();
    const std::vector<std::string> lines = lines_of(render_stats(s, StatsFormat::jsonl));
    ASSERT_EQ(lines.size(), 3U);
    for (const std::string& line : lines) EXPECT_TRUE(JsonChecker(line).object_only()) << line;
    EXPECT_EQ(lines[0].rfind("{\"bus\":{\"source\":\"mem\",", 0), 0U) << lines[0];
    // The untimed exception adds a frame and 5 bytes but no time: 39 characters in 128.3 ms.
    for (const char* key :
         {"\"duration_s\":0.128333", "\"frames\":5", "\"bytes\":39", "\"utilisation_pct\":31.656",
          "\"poll\":{\"slave\":1,", "\"all\":{\"requests\":2,\"answers\":2,\"exceptions\":1,"}) {
        EXPECT_NE(lines[0].find(key), std::string::npos) << key << " in " << lines[0];
    }
    EXPECT_EQ(lines[1].rfind("{\"slave\":1,\"function\":3,\"requests\":2,", 0), 0U) << lines[1];
    EXPECT_NE(lines[1].find("\"turnaround_max_ms\":10.625"), std::string::npos) << lines[1];
    EXPECT_NE(lines[2].find("\"function\":4,"), std::string::npos) << lines[2];
    EXPECT_NE(lines[2].find("\"exception_codes\":{\"2\":1}"), std::string::npos) << lines[2];
    EXPECT_NE(lines[2].find("\"turnaround_p50_ms\":null"), std::string::npos) << lines[2];
}

TEST(StatsJsonl, CheckerRejectsBrokenJson) {
    // The checker must be able to fail, or the test above proves nothing.
    EXPECT_TRUE(JsonChecker(R"({"a":[1,-2.5e3,null,true],"b":{"c":"x\"y\u00e9"}})").object_only());
    for (const char* bad : {"{\"a\":1", "{\"a\":01}", "{\"a\":.5}", "{\"a\":\"x\ty\"}", "{a:1}",
                            "{\"a\":1,}", "[1]", "{\"a\":nul}", "{\"a\":1} x"}) {
        EXPECT_FALSE(JsonChecker(bad).object_only()) << bad;
    }
}

TEST(StatsJsonl, StringsAreEscaped) {
    BusStats s;
    SessionInfo session;
    session.source.name = "we\"ird\n.rtucap";
    session.source.format = "capture";
    s.begin(session);
    s.finish();
    const std::vector<std::string> lines = lines_of(render_stats(s, StatsFormat::jsonl));
    ASSERT_EQ(lines.size(), 1U);
    EXPECT_TRUE(JsonChecker(lines[0]).object_only()) << lines[0];
    EXPECT_NE(lines[0].find(R"("source":"we\"ird\n.rtucap")"), std::string::npos) << lines[0];
}

TEST(StatsRealData, FlowmeterGraphTool) {
    auto source = open_source(RTUSCOPE_SOURCE_DIR "/captures/realdata/flowmeter_graph_tool.rtucap",
                              InputFormat::automatic);
    ASSERT_TRUE(source) << source.error().to_string();
    std::FILE* out = std::tmpfile();
    ASSERT_NE(out, nullptr);
    auto sink = make_stats_sink(out, StatsFormat::csv);
    ASSERT_TRUE(run_pipeline(**source, {}, *sink));
    std::rewind(out);
    std::string csv;
    char buffer[4096];
    for (std::size_t n; (n = std::fread(buffer, 1, sizeof buffer, out)) > 0;) csv.append(buffer, n);
    std::fclose(out);

    const std::vector<std::string> lines = lines_of(csv);
    ASSERT_EQ(lines.size(), 3U) << csv;
    // 18 frames, all slave 247: 9 read requests, each answered (test_pipeline's RealData).
    EXPECT_EQ(lines[1].rfind("247,3,9,9,0,0,0,0,0,9,", 0), 0U) << lines[1];
    EXPECT_EQ(lines[2].rfind("all,all,9,9,0,0,0,0,0,9,", 0), 0U) << lines[2];
}

// Every request has one outcome, on every bundled capture: the row adds up.
TEST(StatsCounts, EveryRequestHasOneOutcomeOnEveryCaptureAsDecodeCountsIt) {
    std::size_t captures = 0;
    for (const auto& entry : std::filesystem::recursive_directory_iterator(
             std::filesystem::path(RTUSCOPE_SOURCE_DIR) / "captures")) {
        const std::string ext = entry.path().extension().string();
        if (!entry.is_regular_file() || ext == ".md" || ext == ".toml") continue;
        SCOPED_TRACE(entry.path().string());
        std::ifstream in(entry.path(), std::ios::binary);
        const std::string content((std::istreambuf_iterator<char>(in)),
                                  std::istreambuf_iterator<char>());
        Totals totals;
        const BusStats s = stats_of(content, InputFormat::automatic, nullptr, &totals);
        for (const auto& [key, row] : s.functions()) {
            EXPECT_EQ(row.requests, row.answers + row.exceptions + row.broken + row.no_answer)
                << "slave " << int{key.first} << " function " << int{key.second};
        }
        const FunctionStats& all = s.all();
        EXPECT_EQ(all.requests, all.answers + all.exceptions + all.broken + all.no_answer);
        // decode's closing lines count by the same rule.
        EXPECT_EQ(all.no_answer, totals.unanswered);
        EXPECT_EQ(all.unsolicited, totals.unsolicited);
        ++captures;
    }
    EXPECT_GT(captures, 20U);
}

// A second answer to one request (two devices on one address) answers no waiting
// request: decode's closing line and stats both count it so.
TEST(StatsCounts, ASecondAnswerCountsAsWithoutRequestInDecodeAndStats) {
    Totals totals;
    const BusStats s = stats_of(
        "01 03 00 00 00 01 84 0A\n01 03 02 08 9D 7E 2D\n01 03 02 08 9D 7E 2D\n",
        InputFormat::hex, nullptr, &totals);
    EXPECT_EQ(s.all().answers, 1U);
    EXPECT_EQ(s.all().unsolicited, 1U);
    EXPECT_EQ(totals.unsolicited, 1U);
}

// A cut-short answer is the request's outcome: broken, not lost between the columns.
TEST(StatsCounts, ACutShortAnswerCountsAsBroken) {
    std::ifstream in(std::filesystem::path(RTUSCOPE_SOURCE_DIR) /
                     "captures/framing/truncated.rtucap");
    const std::string content((std::istreambuf_iterator<char>(in)),
                              std::istreambuf_iterator<char>());
    const BusStats s = stats_of(content, InputFormat::automatic);
    const FunctionStats& row = s.functions().at({1, 3});
    EXPECT_EQ(row.requests, 2U);
    EXPECT_EQ(row.answers, 1U);
    EXPECT_EQ(row.broken, 1U);
    EXPECT_EQ(row.no_answer, 0U);
    EXPECT_NE(render_stats(s, StatsFormat::text).find("req  ans  exc  broken  no ans"),
              std::string::npos);
}

// A device's own function code is named and shown as its profile says, in the rows and in
// the polls: the ZB-UVI485's FC04 is a write of one coefficient, not a read of 18 input
// registers.
TEST(StatsProfiles, RowsAndPollsFollowTheDevicesOwnFunctions) {
    Bus bus;
    ASSERT_TRUE(bus.assign(1, "zb-uvi485"));
    const char* capture =
        "# rtuscope capture v1\n"
        "# serial 9600 8N1\n"
        "0.010000 01 04 00 15 00 12 61 C3\n"
        "0.030000 01 04 00 15 00 12 61 C3\n"
        "0.110000 01 04 00 15 00 12 61 C3\n"
        "0.130000 01 04 00 15 00 12 61 C3\n";
    const BusStats s = stats_of(capture, InputFormat::capture, &bus);
    const std::string text = render_stats(s, StatsFormat::text);
    EXPECT_NE(text.find("1  04  Set correction coefficient"), std::string::npos) << text;
    EXPECT_EQ(text.find("Read Input Registers"), std::string::npos) << text;
    EXPECT_NE(text.find("1  04  00 15 00 12"), std::string::npos) << text;
    EXPECT_EQ(text.find("0x0015 x18"), std::string::npos) << text;
}

// The daily health line: each local day's counts, told when the next day's first record
// or tick comes.
TEST(HealthLine, TellsEachLocalDayItsCountsAtMidnight) {
    for (const char* zone : {"UTC0", "CET-1"}) {
        const test::ScopedZone tz(zone);
        std::vector<std::string> lines;
        HealthOptions options;
        options.emit = [&](const std::string& line) { lines.push_back(line); };
        options.extra = [] { return std::string("3 files written"); };
        auto sink = make_health_sink(options, std::make_unique<test::CollectingSink>());
        SessionInfo session;
        session.source.time_base = TimeBase::unix_time;
        sink->begin(session);
        // 2026-11-27 22:59:50 UTC: 23:59:50 in CET.
        constexpr Nanos kEvening = 1'795'820'390 * kNanosPerSecond;
        Record request;
        request.kind = Kind::request;
        request.awaits_answer = true;
        request.frame.bytes = {1, 3, 0, 0, 0, 1, 0x84, 0x0A};
        Record answer = request;
        answer.kind = Kind::response;
        request.frame.start = kEvening;
        sink->record(request);
        answer.frame.start = kEvening + 5 * kNanosPerSecond;
        sink->record(answer);
        // 20 s later: past midnight in CET, not in UTC.
        request.frame.start = kEvening + 20 * kNanosPerSecond;
        sink->record(request);
        sink->idle(kEvening + 3700 * kNanosPerSecond);  // past midnight UTC too
        sink->end(Totals{}, {});
        if (std::string(zone) == "UTC0") {
            ASSERT_EQ(lines.size(), 1U);
            EXPECT_EQ(lines[0],
                      "health of 2026-11-27: 3 frames (2 requests, 1 answer, 0 exceptions), "
                      "0 errors (0 bad CRC, 0 invalid, 0 noise bytes), 0 requests without answer; "
                      "3 files written");
        } else {
            // The 28th, begun at the third record, is not over.
            ASSERT_EQ(lines.size(), 1U);
            EXPECT_TRUE(lines[0].starts_with("health of 2026-11-27: 2 frames (1 request, 1 answer,"))
                << lines[0];
        }
    }
}

TEST(HealthLine, RelativeTimesHaveNoDays) {
    std::vector<std::string> lines;
    HealthOptions options;
    options.emit = [&](const std::string& line) { lines.push_back(line); };
    auto sink = make_health_sink(options, std::make_unique<test::CollectingSink>());
    SessionInfo session;
    session.source.time_base = TimeBase::relative;
    sink->begin(session);
    Record r;
    r.kind = Kind::request;
    for (Nanos day = 0; day < 3; ++day) {
        r.frame.start = day * kNanosPerDay + 5;
        sink->record(r);
    }
    EXPECT_TRUE(lines.empty());
}

}  // namespace
}  // namespace rtuscope
