// The whole pipeline on real captures and on broken input.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "input/sources.hpp"
#include "pipeline.hpp"
#include "support.hpp"

namespace rtuscope {
namespace {

using test::CollectingSink;

struct RealCapture {
    const char* file;
    std::uint64_t frames;
    std::uint64_t bytes;
};

// Frame and byte counts from the captures' own README (sigrok flowmeter dumps): every
// frame has a valid CRC and every byte belongs to a frame.
class RealData : public ::testing::TestWithParam<RealCapture> {};

TEST_P(RealData, EveryFrameFoundNoNoise) {
    const RealCapture& c = GetParam();
    auto source = open_source(std::string(RTUSCOPE_SOURCE_DIR "/captures/realdata/") + c.file,
                              InputFormat::automatic);
    ASSERT_TRUE(source) << source.error().to_string();
    CollectingSink sink;
    ASSERT_TRUE(run_pipeline(**source, {}, sink));
    EXPECT_EQ(sink.totals.records, c.frames);
    EXPECT_EQ(sink.totals.bytes, c.bytes);
    EXPECT_EQ(sink.totals.noise_bytes, 0U);
    EXPECT_EQ(sink.totals.invalid, 0U);
    EXPECT_EQ(sink.totals.crc_bad + sink.totals.crc_swapped, 0U);
    EXPECT_EQ(sink.totals.unanswered, 0U);
    EXPECT_EQ(sink.totals.requests, c.frames / 2);
    EXPECT_EQ(sink.totals.responses, c.frames / 2);
    for (const Record& r : sink.records) {
        EXPECT_EQ(r.frame.slave(), 247);
        // The slave answers at least 3.8 character times after each request: just above
        // t3.5, so no frame may carry a timing note.
        for (const Note& n : r.notes) ADD_FAILURE() << c.file << " #" << r.number << ": " << n.text;
        if (r.kind == Kind::response) {
            EXPECT_GT(r.latency, sink.session.line.t35());
            EXPECT_LT(r.latency, 20 * kNanosPerSecond / 1000);
        }
    }
}

INSTANTIATE_TEST_SUITE_P(
    Flowmeter, RealData,
    ::testing::Values(RealCapture{"flowmeter_graph_tool.rtucap", 18, 153},
                      RealCapture{"flowmeter_target0_val0.rtucap", 74, 917},
                      RealCapture{"flowmeter_target_0liter_per_min.rtucap", 112, 1391},
                      RealCapture{"flowmeter_target_15liter_per_min.rtucap", 132, 1634},
                      RealCapture{"flowmeter_target_20liter_per_min.rtucap", 66, 831}));

TEST(Pipeline, BadLineStopsWithErrorAfterDecodingEverythingBefore) {
    const std::string capture =
        "# rtuscope capture v1\n"
        "# serial 9600 8N1\n"
        "0.010 01 03 00 00 00 02 C4 0B\n"
        "0.030 01 03 04 00 01 00 02 2A 32\n"
        "0.050 01 03 0G\n";
    auto source = source_from_memory(capture, "cap.rtucap", InputFormat::automatic);
    ASSERT_TRUE(source);
    CollectingSink sink;
    const Status status = run_pipeline(**source, {}, sink);
    ASSERT_FALSE(status);
    EXPECT_EQ(status.error().to_string(), "cap.rtucap:5:13: bad hex byte \"0G\"");
    ASSERT_EQ(sink.records.size(), 2U);
    EXPECT_EQ(sink.records[1].kind, Kind::response);
    EXPECT_TRUE(sink.ended);
}

TEST(Pipeline, OptionsOverrideTheCaptureHeader) {
    auto source = source_from_memory("# rtuscope capture v1\n# serial 19200 8E1\n0.1 01\n", "cap",
                                     InputFormat::capture);
    ASSERT_TRUE(source);
    PipelineOptions options;
    options.baud = 4800;
    CollectingSink sink;
    ASSERT_TRUE(run_pipeline(**source, options, sink));
    EXPECT_EQ(sink.session.line.baud, 4800U);
    EXPECT_EQ(sink.session.line.format(), "8E1");
    options.format = *parse_line_format("8N2");
    auto again = source_from_memory("# rtuscope capture v1\n# serial 19200 8E1\n0.1 01\n", "cap",
                                    InputFormat::capture);
    CollectingSink sink2;
    ASSERT_TRUE(run_pipeline(**again, options, sink2));
    EXPECT_EQ(sink2.session.line.format(), "8N2");
    EXPECT_EQ(sink2.session.line.baud, 4800U);
}

TEST(LineSettings, CharacterTimesAndFixedTimersAbove19200) {
    LineSettings line;
    EXPECT_EQ(line.bits_per_char(), 10U);
    EXPECT_EQ(line.char_time(), 1'041'666);
    EXPECT_EQ(line.t35(), 3'645'831);
    auto even = parse_line_format("8e1");
    ASSERT_TRUE(even);
    EXPECT_EQ(even->bits_per_char(), 11U);
    LineSettings fast;
    fast.baud = 38400;
    EXPECT_EQ(fast.t15(), 750'000);
    EXPECT_EQ(fast.t35(), 1'750'000);
    EXPECT_FALSE(parse_line_format("9N1"));
    EXPECT_FALSE(parse_line_format("8X1"));
    EXPECT_FALSE(parse_baud("96OO"));
}

}  // namespace
}  // namespace rtuscope

namespace rtuscope {
namespace {

// A request, then the first 3 bytes of its answer when the input stops: the end of a
// file is the end of what was on the line (the answer was cut short), but a live run that
// is stopped (--seconds, a signal, the end of the stream) cut it itself: no bus error, and
// the request waited for an answer that could still have come.
const char* const kStoppedMidAnswer =
    "# rtuscope capture v1\n"
    "# serial 9600 8N1\n"
    "0.010000 01 03 00 00 00 02 C4 0B\n"
    "0.020000 01 03 04\n";

TEST(PipelineStop, AFrameCutByTheStopIsNoError) {
    for (const bool live : {false, true}) {
        SCOPED_TRACE(live ? "live" : "file");
        auto source = source_from_memory(kStoppedMidAnswer, "mem", InputFormat::capture);
        ASSERT_TRUE(source);
        PipelineOptions options;
        options.live = live;
        CollectingSink sink;
        ASSERT_TRUE(run_pipeline(**source, options, sink));
        ASSERT_EQ(sink.records.size(), 2U);
        const Record& cut = sink.records[1];
        EXPECT_EQ(cut.frame.bytes, (test::Bytes{0x01, 0x03, 0x04}));
        EXPECT_EQ(cut.notes.has(note_id::cut_by_stop), live);
        EXPECT_EQ(cut.notes.has(note_id::truncated), !live);
        EXPECT_EQ(sink.totals.invalid, live ? 0U : 1U);
        EXPECT_EQ(sink.totals.cut_by_stop_bytes, live ? 3U : 0U);
        const Record& request = sink.records[0];
        EXPECT_EQ(request.notes.has(note_id::stopped_before_answer), live);
        EXPECT_EQ(sink.totals.unanswered, 0U);  // the broken answer, or the stop
    }
}

// A stop asked for (a signal) ends a decode of a file at the chunk it comes: here before
// the first, so nothing is read, and the run still ends cleanly.
TEST(PipelineStop, AStopFlagEndsTheRunAtTheNextChunk) {
    auto source = source_from_memory(kStoppedMidAnswer, "mem", InputFormat::capture);
    ASSERT_TRUE(source);
    std::atomic<bool> stop{false};
    PipelineOptions options;
    options.stop = &stop;
    CollectingSink sink;
    stop.store(true);
    ASSERT_TRUE(run_pipeline(**source, options, sink));
    EXPECT_TRUE(sink.records.empty());
    EXPECT_TRUE(sink.ended);
}

}  // namespace
}  // namespace rtuscope
