// The report's series (src/report/series.hpp): buckets that widen as a capture grows
// without losing a count, the turnaround histogram's bins, values and writes per
// register, the flagged records kept up to their limit; and the page's pieces.
#include <gtest/gtest.h>

#include <numeric>
#include <string>

#include "report/html_report.hpp"
#include "report/series.hpp"
#include "stats/report.hpp"
#include "support.hpp"

namespace rtuscope::report {
namespace {

using test::Bytes;
using test::with_crc;

Record frame_at(Kind kind, Bytes bytes, Nanos start) {
    Record r;
    r.kind = kind;
    r.awaits_answer = kind == Kind::request;
    r.frame.bytes = std::move(bytes);
    r.frame.cls = kind == Kind::noise ? RecordClass::noise : RecordClass::frame;
    r.frame.crc = kind == Kind::noise ? CrcCheck{} : check_crc(r.frame.bytes);
    r.frame.start = start;
    r.frame.end = start + 1'000'000;
    return r;
}

std::uint64_t total_frames(const Series& s) {
    return std::accumulate(s.bus().begin(), s.bus().end(), std::uint64_t{0},
                           [](std::uint64_t n, const BusBucket& b) { return n + b.frames; });
}

TEST(ReportSeries, BucketsWidenAsTheCaptureGrowsAndKeepEveryFrame) {
    Series series(10);
    series.begin({});
    const Nanos second = kNanosPerSecond;
    const Bytes read = with_crc({0x01, 0x03, 0x00, 0x00, 0x00, 0x01});
    // One frame a second for three hours: 10,800 s, far beyond 1,000 buckets of 100 ms.
    for (Nanos t = 0; t < 10'800; ++t) series.add(frame_at(Kind::request, read, 1'000 * second + t * second));
    EXPECT_LE(series.bus().size(), kMaxBuckets);
    EXPECT_GT(series.bus().size(), kMaxBuckets / 2);
    EXPECT_EQ(total_frames(series), 10'800U);
    EXPECT_EQ(series.width(), kFirstBucketWidth * 128);  // 12.8 s: 844 buckets
    EXPECT_EQ(series.origin(), 1'000 * second);
    // The poll repeats every second: every cycle counted, at 1,000 ms.
    const SlaveSeries& slave = series.slaves().at(1);
    std::uint64_t cycles = 0;
    double sum = 0;
    for (const SlaveBucket& b : slave.buckets) {
        cycles += b.cycles;
        sum += b.cycle_sum_ms;
    }
    EXPECT_EQ(cycles, 10'799U);
    EXPECT_NEAR(sum / static_cast<double>(cycles), 1000.0, 1e-3);
}

TEST(ReportSeries, ErrorsCountedByKind) {
    Series series(10);
    series.begin({});
    Bytes bad = with_crc({0x02, 0x03, 0x02, 0x00, 0x01});
    bad.back() ^= 0xFF;
    Record crc = frame_at(Kind::invalid, bad, kNanosPerSecond);
    crc.frame.cls = RecordClass::invalid;
    series.add(crc);
    series.add(frame_at(Kind::noise, {0xFF, 0x00}, 2 * kNanosPerSecond));
    series.add(frame_at(Kind::exception, with_crc({0x02, 0x83, 0x02}), 3 * kNanosPerSecond));
    const auto count = [&](ErrorKind kind) {
        std::uint64_t n = 0;
        for (const BusBucket& b : series.bus()) n += b.errors.at(static_cast<std::size_t>(kind));
        return n;
    };
    EXPECT_EQ(count(ErrorKind::crc), 1U);
    EXPECT_EQ(count(ErrorKind::noise), 1U);
    EXPECT_EQ(count(ErrorKind::exception), 1U);
    EXPECT_EQ(count(ErrorKind::no_answer), 0U);
    EXPECT_EQ(total_frames(series), 2U);  // noise is no frame
    // A frame with a bad CRC counts for no slave: its address cannot be believed.
    EXPECT_EQ(series.slaves().count(2), 1U);
    EXPECT_EQ(series.slaves().at(2).frames, 1U);
}

TEST(ReportSeries, HistogramBinsAreTenthsOfADecade) {
    EXPECT_EQ(histogram_bin(0), 0U);
    EXPECT_EQ(histogram_bin(0.005), 0U);
    EXPECT_EQ(histogram_bin(0.01), 1U);
    EXPECT_EQ(histogram_bin(1.0), 21U);     // two decades above 10 µs
    EXPECT_EQ(histogram_bin(1.3), 22U);     // 10^0.1 = 1.26 ms starts the next bin
    EXPECT_EQ(histogram_bin(1e9), kHistogramBins - 1);
    EXPECT_DOUBLE_EQ(histogram_edge_ms(21), 1.0);
    EXPECT_LE(histogram_edge_ms(histogram_bin(5.0)), 5.0);
    EXPECT_GT(histogram_edge_ms(histogram_bin(5.0) + 1), 5.0);
}

TEST(ReportSeries, FlaggedRecordsKeptUpToTheLimitAndCounted) {
    Series series(2);
    series.begin({});
    for (int i = 0; i < 5; ++i) {
        Record r = frame_at(Kind::request, with_crc({0x01, 0x03, 0x00, 0x00, 0x00, 0x01}),
                            (i + 1) * kNanosPerSecond);
        r.number = static_cast<std::uint64_t>(i + 1);
        r.notes.add(note_id::no_answer, "no answer within 1 s");
        series.add(r);
    }
    ASSERT_EQ(series.flagged().size(), 2U);
    EXPECT_EQ(series.flagged_count(), 5U);
    EXPECT_EQ(series.flagged()[1].number, 2U);
    EXPECT_EQ(series.flagged()[0].notes.at(0).first, note_id::no_answer);
}

TEST(ReportPage, EmbedsTheStatisticsAsStatsPrintsThem) {
    BusStats stats;
    SessionInfo session;
    session.source.name = "x</script>y";
    stats.begin(session);
    Series series(10);
    series.begin(session);
    Record r = frame_at(Kind::request, with_crc({0x01, 0x03, 0x00, 0x00, 0x00, 0x01}), kNanosPerSecond);
    stats.add(r);
    series.add(r);
    stats.finish();
    const std::string page = render_html(stats, series, {});
    std::string jsonl = render_stats(stats, StatsFormat::jsonl);
    ASSERT_NE(jsonl.find("x</script>y"), std::string::npos);
    jsonl.replace(jsonl.find("x</script>y"), 11, "x\\u003c/script>y");
    EXPECT_NE(page.find("<script type=\"application/jsonl\" id=\"stats-jsonl\">\n" + jsonl + "</script>"),
              std::string::npos);
    EXPECT_EQ(page.find("x</script>y"), std::string::npos);
    EXPECT_EQ(page.find("{{"), std::string::npos) << "a mark of the template left unfilled";
    EXPECT_NE(page.find("Leon Sorokin"), std::string::npos) << "uPlot's licence";
}

}  // namespace
}  // namespace rtuscope::report
