// Live input: PARMRK unescaping, the framer and the pairing deciding on idle time, the
// capture writer's lines, and a tty source reading a pseudo-terminal.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <thread>
#include <chrono>

#include "input/capture_writer.hpp"
#include "recording/recorder.hpp"
#include "input/sources.hpp"
#include "input/tty.hpp"
#include "pipeline.hpp"
#include "support.hpp"

namespace rtuscope {
namespace {

using test::Bytes;
using test::kMs;
using test::with_crc;

TEST(Parmrk, UnescapesDataAndMarksErrors) {
    ParmrkDecoder d;
    Bytes out;
    std::vector<std::uint32_t> errors;
    // 01, an escaped data byte FF, a byte 55 with a parity error, 02.
    d.feed(Bytes{0x01, 0xFF, 0xFF, 0xFF, 0x00, 0x55, 0x02}, out, errors);
    EXPECT_EQ(out, (Bytes{0x01, 0xFF, 0x55, 0x02}));
    EXPECT_EQ(errors, (std::vector<std::uint32_t>{2}));
}

TEST(Parmrk, EscapeSplitAcrossReads) {
    ParmrkDecoder d;
    Bytes out;
    std::vector<std::uint32_t> errors;
    d.feed(Bytes{0x10, 0xFF}, out, errors);
    EXPECT_EQ(out, Bytes{0x10});
    d.feed(Bytes{0x00}, out, errors);
    EXPECT_EQ(out, Bytes{0x10});
    d.feed(Bytes{0x00, 0x20}, out, errors);  // a break: FF 00 00
    EXPECT_EQ(out, (Bytes{0x10, 0x00, 0x20}));
    EXPECT_EQ(errors, (std::vector<std::uint32_t>{1}));
}

// The frames of `times` reads of one register from slave 1, in one chunk whose bytes
// `char_errors` (offsets in the chunk) the UART flagged.
std::vector<Frame> frame_reads_with_char_errors(int times, std::vector<std::uint32_t> char_errors) {
    const Bytes read = with_crc({0x01, 0x03, 0x00, 0x00, 0x00, 0x01});
    std::vector<Frame> frames;
    Framer framer(FramerOptions{}, [&](const Frame& f) { frames.push_back(f); });
    Chunk chunk;
    chunk.time = 100 * kMs;
    for (int i = 0; i < times; ++i) chunk.bytes.insert(chunk.bytes.end(), read.begin(), read.end());
    chunk.char_errors = std::move(char_errors);
    framer.push(chunk);
    framer.finish();
    return frames;
}

TEST(LiveFramer, CharErrorIsNotedOnTheFrameItHits) {
    const std::vector<Frame> frames = frame_reads_with_char_errors(1, {3});
    ASSERT_EQ(frames.size(), 1U);
    ASSERT_FALSE(frames[0].notes.empty());
    EXPECT_STREQ(frames[0].notes.back().id, note_id::char_error);
    EXPECT_EQ(frames[0].notes.back().text, "parity/framing error on byte 4");
}

TEST(LiveFramer, CharErrorsListedOutOfOrderNoteEachFrameTheyHit) {
    const std::vector<Frame> frames = frame_reads_with_char_errors(2, {10, 2, 6});
    ASSERT_EQ(frames.size(), 2U);
    ASSERT_FALSE(frames[0].notes.empty());
    EXPECT_EQ(frames[0].notes.back().text, "parity/framing error on byte 3, 7");
    ASSERT_FALSE(frames[1].notes.empty());
    EXPECT_EQ(frames[1].notes.back().text, "parity/framing error on byte 3");
}

TEST(LiveFramer, AmbiguousFrameIsDecidedWhenTheLineGoesIdle) {
    // 01 03 04 00 00 02 + CRC is a complete request, but its third byte could also be the
    // byte count of a 9-byte answer: the framer waits for more, until the line is idle.
    const Bytes request = with_crc({0x01, 0x03, 0x04, 0x00, 0x00, 0x02});
    std::vector<Frame> frames;
    FramerOptions o;
    Framer framer(o, [&](const Frame& f) { frames.push_back(f); });
    const Nanos end = 100 * kMs;
    framer.push(Chunk{end, "", request, 0, {}});
    EXPECT_TRUE(frames.empty());
    const Nanos margin = 20 * kMs;
    framer.idle(end + o.line.t35() + margin - 1, margin);
    EXPECT_TRUE(frames.empty());
    framer.idle(end + o.line.t35() + margin, margin);
    ASSERT_EQ(frames.size(), 1U);
    EXPECT_EQ(frames[0].bytes, request);
    EXPECT_EQ(frames[0].reading, Reading::request);
    EXPECT_EQ(frames[0].crc.status, CrcStatus::ok);
    // The next frame starts after that silence and is found as usual.
    const Bytes next = with_crc({0x02, 0x03, 0x00, 0x10, 0x00, 0x01});
    framer.push(Chunk{end + 200 * kMs, "", next, 0, {}});
    framer.finish();
    ASSERT_EQ(frames.size(), 2U);
    EXPECT_EQ(frames[1].bytes, next);
}

TEST(LiveFramer, OnATwoPortTapThePortSaysWhichFramesAreRequests) {
    // A write and its echo are byte for byte the same: only the port tells them apart,
    // even when the order alone would say otherwise (the request was not heard).
    const Bytes write = with_crc({0x01, 0x06, 0x00, 0x01, 0x00, 0x03});
    std::vector<Frame> frames;
    FramerOptions o;
    Framer framer(o, [&](const Frame& f) { frames.push_back(f); });
    framer.push(Chunk{10 * kMs, "slave", write, 0, {}});
    framer.push(Chunk{30 * kMs, "master", write, 0, {}});
    framer.push(Chunk{50 * kMs, "slave", write, 0, {}});
    framer.finish();
    ASSERT_EQ(frames.size(), 3U);
    EXPECT_EQ(frames[0].reading, Reading::response);
    EXPECT_EQ(frames[0].channel, "slave");
    EXPECT_EQ(frames[1].reading, Reading::request);
    EXPECT_EQ(frames[2].reading, Reading::response);
}

TEST(LiveTransactions, TimeoutIsDecidedByTheClockNotTheNextFrame) {
    const Bytes read = with_crc({0x01, 0x03, 0x00, 0x00, 0x00, 0x02});
    std::vector<Record> records;
    Transactions t({kNanosPerSecond, &standard_rules()},
                   [&](Record&& r) { records.push_back(std::move(r)); });
    Frame f;
    f.bytes = read;
    f.cls = RecordClass::frame;
    f.reading = Reading::request;
    f.start = 0;
    f.end = 10 * kMs;
    t.push(f);
    t.tick(900 * kMs);
    EXPECT_TRUE(records.empty());  // still waiting for the answer
    t.tick(1011 * kMs);
    ASSERT_EQ(records.size(), 1U);
    EXPECT_TRUE(records[0].notes.has(note_id::no_answer));
    EXPECT_EQ(records[0].notes.back().text, "no answer within 1 s");
}

TEST(CaptureWriter, LinesReadBackAsTheSameChunks) {
    Chunk a{1763798400'022360123, "", {0x01, 0x03, 0xFF}, 0, {}};
    Chunk b{1763798400'038384000, "B", {0x00}, 0, {}};
    EXPECT_EQ(capture_line(a), "1763798400.022360123 01 03 FF\n");
    EXPECT_EQ(capture_line(b), "1763798400.038384000 @B 00\n");
    auto source = source_from_memory(
        "# rtuscope capture v1\n# serial 19200 8E1\n" + capture_line(a) + capture_line(b), "mem",
        InputFormat::automatic);
    ASSERT_TRUE(source);
    Chunk got;
    ASSERT_TRUE(*(*source)->next(got));
    EXPECT_EQ(got.time, a.time);
    EXPECT_EQ(got.bytes, a.bytes);
    ASSERT_TRUE(*(*source)->next(got));
    EXPECT_EQ(got.time, b.time);
    EXPECT_EQ(got.channel, "B");
    ASSERT_TRUE((*source)->info().line);
    EXPECT_EQ((*source)->info().line->format(), "8E1");
}

// A pseudo-terminal stands in for the adapter: the test writes on the master side, the
// source reads the slave side exactly as it reads /dev/ttyUSB0.
struct Pty {
    Pty() {
        master = posix_openpt(O_RDWR | O_NOCTTY);
        EXPECT_GE(master, 0);
        EXPECT_EQ(grantpt(master), 0);
        EXPECT_EQ(unlockpt(master), 0);
        path = ptsname(master);
    }
    ~Pty() {
        if (master >= 0) close(master);
    }
    void write_bytes(const Bytes& b) const {
        EXPECT_EQ(write(master, b.data(), b.size()), static_cast<ssize_t>(b.size()));
    }
    int master = -1;
    std::string path;
};

// Reads chunks until `want` bytes came (ticks skipped) or 2 s pass.
Bytes read_bytes(ChunkSource& source, std::size_t want, std::vector<std::uint32_t>* errors) {
    Bytes got;
    Chunk chunk;
    for (int i = 0; i < 400 && got.size() < want; ++i) {
        auto more = source.next(chunk);
        if (!more.ok() || !*more) break;
        for (const std::uint32_t e : chunk.char_errors) {
            if (errors != nullptr) errors->push_back(static_cast<std::uint32_t>(got.size() + e));
        }
        got.insert(got.end(), chunk.bytes.begin(), chunk.bytes.end());
    }
    return got;
}

// 115200 baud 8N1: a character takes 86.8 us, and t1.5 is the fixed 750 us.
constexpr Nanos kChar = 86'805;
constexpr Nanos kWindow = 750'000;

LineSettings fast_line() {
    LineSettings line;
    line.baud = 115200;
    return line;
}

TEST(ReadBatcher, TheFirstByteAfterASilenceIsStampedAsItArrivesAndStartsABatch) {
    ReadBatcher batcher(fast_line());
    EXPECT_FALSE(batcher.batching());
    EXPECT_EQ(batcher.stamp(1'000'000, 1), 1'000'000);
    EXPECT_TRUE(batcher.batching());
    EXPECT_EQ(batcher.next_read(), 1'000'000 + kWindow);
}

TEST(ReadBatcher, AWindowTheLineFilledIsStampedWhenReadAndTheBatchGoesOn) {
    ReadBatcher batcher(fast_line());
    batcher.stamp(1'000'000, 1);
    // 760 us later, 8 characters (694 us) and part of a ninth: the line never stopped.
    EXPECT_EQ(batcher.stamp(1'760'000, 8), 1'000'000 + 8 * kChar);
    EXPECT_TRUE(batcher.batching());
    // A read that comes late finds more than the time could hold: stamped when read.
    EXPECT_EQ(batcher.stamp(2'300'000, 12), 2'300'000);
    EXPECT_TRUE(batcher.batching());
}

TEST(ReadBatcher, AWindowWithASilenceEndsTheBatchWithTheSilenceAfterItsBytes) {
    ReadBatcher batcher(fast_line());
    batcher.stamp(1'000'000, 1);
    // Three characters in 760 us: the frame ended 260 us after the last read.
    EXPECT_EQ(batcher.stamp(1'760'000, 3), 1'000'000 + 3 * kChar);
    EXPECT_FALSE(batcher.batching());
    // The next byte wakes the reader again, and is stamped as it arrives.
    EXPECT_EQ(batcher.stamp(5'000'000, 1), 5'000'000);
    EXPECT_TRUE(batcher.batching());
}

TEST(ReadBatcher, AReadLongAfterItsWindowIsStampedWhenItCame) {
    ReadBatcher batcher(fast_line());
    batcher.stamp(1'000'000, 1);
    EXPECT_EQ(batcher.stamp(31'000'000, 3), 31'000'000);
    EXPECT_TRUE(batcher.batching());
}

TEST(ReadBatcher, AnEmptyReadEndsTheBatch) {
    ReadBatcher batcher(fast_line());
    batcher.stamp(1'000'000, 1);
    batcher.stamp(1'760'000, 0);
    EXPECT_FALSE(batcher.batching());
}

TEST(TtySource, ReadsWhatArrivesWithWallTimes) {
    Pty pty;
    TtyOptions o;
    o.ports = {pty.path};
    auto source = open_tty_source(o);
    ASSERT_TRUE(source) << source.error().to_string();
    EXPECT_EQ((*source)->info().format, "live");
    EXPECT_TRUE((*source)->info().timed);
    // Nothing yet: a tick, with a time and no bytes.
    Chunk tick;
    ASSERT_TRUE(*(*source)->next(tick));
    EXPECT_TRUE(tick.bytes.empty());
    EXPECT_GT(tick.time, 1'600'000'000LL * kNanosPerSecond);  // wall time, not uptime
    // 0xFF must come through as one data byte: PARMRK doubles it on the way.
    const Bytes frame = with_crc({0x01, 0x03, 0x02, 0xFF, 0x10});
    pty.write_bytes(frame);
    EXPECT_EQ(read_bytes(**source, frame.size(), nullptr), frame);
}

TEST(TtySource, StopsAfterItsDuration) {
    Pty pty;
    TtyOptions o;
    o.ports = {pty.path};
    o.duration = 50 * kMs;
    auto source = open_tty_source(o);
    ASSERT_TRUE(source);
    Chunk chunk;
    int calls = 0;
    while (calls < 1000 && *(*source)->next(chunk)) ++calls;
    EXPECT_LT(calls, 1000);  // it ended by itself
}

TEST(TtySource, HangUpEndsWithAClearError) {
    auto pty = std::make_unique<Pty>();
    TtyOptions o;
    o.ports = {pty->path};
    auto source = open_tty_source(o);
    ASSERT_TRUE(source);
    pty.reset();  // the adapter is gone
    Chunk chunk;
    Result<bool> more = true;
    for (int i = 0; i < 100 && more.ok() && *more; ++i) more = (*source)->next(chunk);
    ASSERT_FALSE(more.ok());
    EXPECT_NE(more.error().message.find("was the adapter unplugged?"), std::string::npos)
        << more.error().message;
}

TEST(TtySource, WithReopenAPortThatComesBackIsReadAgainAfterAGap) {
    // The port is a name (as /dev/serial/by-id names are links) that goes away with its
    // adapter and comes back pointing at the new device.
    const test::TempDir dir;
    const std::string port = dir.file("ttyUSB0");
    auto first = std::make_unique<Pty>();
    ASSERT_EQ(symlink(first->path.c_str(), port.c_str()), 0);
    std::atomic<bool> stop{false};
    std::vector<std::string> notices;
    TtyOptions o;
    o.ports = {port};
    o.reopen = true;
    o.reopen_poll = 20 * kMs;
    o.stop = &stop;
    o.on_notice = [&](const std::string& notice) { notices.push_back(notice); };
    auto source = open_tty_source(o);
    ASSERT_TRUE(source) << source.error().to_string();
    const test::TempDir out;
    const std::string capture = out.file("gap.rtucap");
    auto recording = record_capture(std::move(*source), capture, SourceInfo{});
    ASSERT_TRUE(recording);

    first->write_bytes({0x01, 0x02});
    EXPECT_EQ(read_bytes(**recording, 2, nullptr), (Bytes{0x01, 0x02}));
    first.reset();  // unplugged
    ASSERT_EQ(unlink(port.c_str()), 0);
    Pty second;  // plugged in again
    std::thread replug([&] {
        std::this_thread::sleep_for(std::chrono::milliseconds(300));
        ASSERT_EQ(symlink(second.path.c_str(), port.c_str()), 0);
    });
    Chunk chunk;
    Nanos gap = kNoTime;
    for (int i = 0; i < 1000 && !has_time(gap); ++i) {
        ASSERT_TRUE((*recording)->next(chunk));
        if (has_time(chunk.gap_since)) gap = chunk.time - chunk.gap_since;
    }
    replug.join();
    ASSERT_TRUE(has_time(gap));
    EXPECT_GE(gap, 250 * kMs);
    second.write_bytes({0x03, 0x04});
    EXPECT_EQ(read_bytes(**recording, 2, nullptr), (Bytes{0x03, 0x04}));
    stop.store(true);
    ASSERT_FALSE(*(*recording)->next(chunk));  // the capture ends with its `# stopped` line

    ASSERT_EQ(notices.size(), 2U);
    EXPECT_NE(notices[0].find("waiting for it to come back"), std::string::npos) << notices[0];
    EXPECT_NE(notices[1].find("was gone from"), std::string::npos) << notices[1];
    ASSERT_EQ((*recording)->remarks().size(), 1U);
    // The capture says so, and so does its decode.
    std::ifstream in(capture);
    const std::string text{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    EXPECT_NE(text.find("# gap "), std::string::npos) << text;
    auto read_back = open_source(capture, InputFormat::capture);
    ASSERT_TRUE(read_back);
    Chunk c;
    while (*(*read_back)->next(c)) {
    }
    ASSERT_EQ((*read_back)->remarks().size(), 1U);
    EXPECT_NE((*read_back)->remarks()[0].find("the port was gone from"), std::string::npos);
}

TEST(TtySource, OpenErrorsNameTheFix) {
    TtyOptions o;
    o.ports = {"/dev/no-such-adapter"};
    auto missing = open_tty_source(o);
    ASSERT_FALSE(missing);
    EXPECT_EQ(missing.error().to_string(),
              "/dev/no-such-adapter: cannot open: No such file or directory (is the adapter "
              "plugged in? ls /dev/ttyUSB* /dev/ttyACM* /dev/serial/by-id)");
    o.ports = {"/dev/null"};
    auto not_a_tty = open_tty_source(o);
    ASSERT_FALSE(not_a_tty);
    EXPECT_EQ(not_a_tty.error().to_string(),
              "/dev/null: not a serial port (to decode a file, use rtuscope decode)");
}

TEST(TtySource, ASilenceBetweenBatchesIsMeasuredAsItWas) {
    Pty pty;
    TtyOptions o;
    o.ports = {pty.path};
    auto source = open_tty_source(o);
    ASSERT_TRUE(source);
    const auto next_bytes = [&](Chunk& chunk) {
        for (int i = 0; i < 400; ++i) {
            if (!*(*source)->next(chunk)) return false;
            if (!chunk.bytes.empty()) return true;
        }
        return false;
    };
    pty.write_bytes(Bytes{0x01, 0x03, 0x00});
    Chunk first;
    ASSERT_TRUE(next_bytes(first));
    // The reader's window passes empty while the line is quiet for 30 ms.
    std::this_thread::sleep_for(std::chrono::milliseconds(30));
    pty.write_bytes(Bytes{0x00, 0x00, 0x01});
    Chunk second;
    ASSERT_TRUE(next_bytes(second));
    EXPECT_GE(second.time - first.time, 30 * kMs);
}

TEST(TtySource, TwoPortsAreTaggedWithTheirChannels) {
    Pty master_side;
    Pty slave_side;
    TtyOptions o;
    o.ports = {master_side.path, slave_side.path};
    auto source = open_tty_source(o);
    ASSERT_TRUE(source) << source.error().to_string();
    master_side.write_bytes(Bytes{0x01});
    Chunk chunk;
    for (int i = 0; i < 400; ++i) {
        ASSERT_TRUE(*(*source)->next(chunk));
        if (!chunk.bytes.empty()) break;
    }
    EXPECT_EQ(chunk.channel, "master");
    slave_side.write_bytes(Bytes{0x02});
    for (int i = 0; i < 400; ++i) {
        ASSERT_TRUE(*(*source)->next(chunk));
        if (!chunk.bytes.empty()) break;
    }
    EXPECT_EQ(chunk.channel, "slave");
    EXPECT_EQ(chunk.bytes, Bytes{0x02});
}

TEST(LivePipeline, RecordsAreFlushedWhileTheLineRunsAndTheCaptureMatches) {
    Pty pty;
    TtyOptions o;
    o.ports = {pty.path};
    o.duration = 500 * kMs;
    auto source = open_tty_source(o);
    ASSERT_TRUE(source);
    const test::TempDir dir;
    const std::string path = dir.file("live.rtucap");
    const SourceInfo header = (*source)->info();
    auto recording = record_capture(std::move(*source), path, header);
    ASSERT_TRUE(recording);
    const Bytes read = with_crc({0x01, 0x03, 0x00, 0x00, 0x00, 0x01});
    const Bytes answer = with_crc({0x01, 0x03, 0x02, 0x18, 0x18});

    // The slave answers once the request has been read; the source notes when it ends.
    struct Answering final : ChunkSource {
        Answering(ChunkSource& in, Pty& p, Bytes a) : inner(in), pty(p), answer(std::move(a)) {}
        const SourceInfo& info() const override { return inner.info(); }
        Result<bool> next(Chunk& out) override {
            Result<bool> more = inner.next(out);
            if (more.ok() && *more && !out.bytes.empty() && !answered) {
                pty.write_bytes(answer);
                answered = true;
            }
            if (!more.ok() || !*more) ended = true;
            return more;
        }
        ChunkSource& inner;
        Pty& pty;
        Bytes answer;
        bool answered = false;
        bool ended = false;
    };
    Answering answering(**recording, pty, answer);
    pty.write_bytes(read);

    struct Collect final : RecordSink {
        explicit Collect(const bool* e) : ended(e) {}
        void begin(const SessionInfo& /*s*/) override {}
        void record(const Record& r) override {
            records.push_back(r);
            if (ended != nullptr && !*ended) ++while_running;
        }
        void end(const Totals& /*t*/, const std::vector<std::string>& /*r*/) override {}
        void flush() override { ++flushes; }
        const bool* ended;
        std::vector<Record> records;
        int while_running = 0;
        int flushes = 0;
    } sink(&answering.ended);
    PipelineOptions options;
    options.live = true;
    ASSERT_TRUE(run_pipeline(answering, options, sink));
    ASSERT_EQ(sink.records.size(), 2U);
    EXPECT_EQ(sink.records[0].kind, Kind::request);
    EXPECT_EQ(sink.records[1].kind, Kind::response);
    EXPECT_EQ(sink.records[1].request_number, 1U);
    // Both came out while the line was still being read, each flushed at once.
    EXPECT_EQ(sink.while_running, 2);
    EXPECT_EQ(sink.flushes, 2);
    recording->reset();  // closes the file

    // The recorded capture decodes offline to the same records.
    auto offline = open_source(path, InputFormat::automatic);
    ASSERT_TRUE(offline);
    Collect again(nullptr);
    ASSERT_TRUE(run_pipeline(**offline, {}, again));
    ASSERT_EQ(again.records.size(), 2U);
    EXPECT_EQ(again.flushes, 0);  // a file's decode writes in large blocks
    for (std::size_t i = 0; i < 2; ++i) {
        EXPECT_EQ(again.records[i].frame.bytes, sink.records[i].frame.bytes);
        EXPECT_EQ(again.records[i].frame.start, sink.records[i].frame.start);
        EXPECT_EQ(again.records[i].kind, sink.records[i].kind);
    }
}

}  // namespace
}  // namespace rtuscope
