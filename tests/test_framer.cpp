// The framer on each real-world case that breaks the t3.5 rule (framer.hpp), fed through
// the pairing stage as in the pipeline (the pairing tells the framer which answer the bus
// awaits).
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <map>
#include <set>
#include <sstream>

#include "framing/framer.hpp"
#include "support.hpp"

namespace rtuscope {
namespace {

using test::Bytes;
using test::concat;
using test::Harness;
using test::kMs;
using test::Line;
using test::with_crc;

const Bytes kRead = with_crc({0x01, 0x03, 0x00, 0x00, 0x00, 0x02});              // 8 bytes
const Bytes kReadAnswer = with_crc({0x01, 0x03, 0x04, 0x17, 0xF8, 0x00, 0x2A});  // 9 bytes
const Bytes kWrite = with_crc({0x02, 0x06, 0x00, 0x01, 0x00, 0x03});             // echo
const Bytes kWriteMany =
    with_crc({0x03, 0x10, 0x00, 0x01, 0x00, 0x02, 0x04, 0x00, 0x0A, 0x01, 0x02});
const Bytes kWriteManyAnswer = with_crc({0x03, 0x10, 0x00, 0x01, 0x00, 0x02});

void expect_frame(const Record& r, const Bytes& bytes, Kind kind) {
    EXPECT_EQ(r.frame.bytes, bytes);
    EXPECT_EQ(r.kind, kind) << "record " << r.number << " is " << to_string(r.kind);
    EXPECT_EQ(r.frame.crc.status, CrcStatus::ok);
}

void expect_noise(const Record& r, const Bytes& bytes) {
    EXPECT_EQ(r.kind, Kind::noise);
    EXPECT_EQ(r.frame.bytes, bytes);
}

// Case 1: a USB adapter hands bytes over in 16 ms batches.
TEST(Framer, UsbBatchesWithRequestAndAnswerInOneChunk) {
    Line line;
    line.deliver_at(16 * kMs, concat({kRead, kReadAnswer}))
        .deliver_at(48 * kMs, concat({kWrite, Bytes(kWrite.begin(), kWrite.begin() + 3)}))
        .deliver_at(64 * kMs, Bytes(kWrite.begin() + 3, kWrite.end()))
        .deliver_at(96 * kMs, Bytes(kWriteMany.begin(), kWriteMany.begin() + 5))
        .deliver_at(112 * kMs,
                    concat({Bytes(kWriteMany.begin() + 5, kWriteMany.end()), kWriteManyAnswer}));
    Harness h;
    const auto& r = h.run(line.chunks());
    ASSERT_EQ(r.size(), 6U);
    expect_frame(r[0], kRead, Kind::request);
    expect_frame(r[1], kReadAnswer, Kind::response);
    EXPECT_EQ(r[1].request_number, 1U);
    expect_frame(r[2], kWrite, Kind::request);
    expect_frame(r[3], kWrite, Kind::response);  // the echo, split over two batches
    EXPECT_EQ(r[3].request_number, 3U);
    expect_frame(r[4], kWriteMany, Kind::request);
    expect_frame(r[5], kWriteManyAnswer, Kind::response);
    EXPECT_EQ(h.output_bytes(), h.input_bytes);
    // Batching hides the real silences: no timing complaints from it.
    for (const Record& rec : r) {
        EXPECT_FALSE(rec.notes.has(note_id::gap_inside)) << rec.number;
        EXPECT_FALSE(rec.notes.has(note_id::short_gap)) << rec.number;
    }
}

// Case 2: a slave that answers 2.5-3 character times after the request (< t3.5).
TEST(Framer, FastAnswerBelowT35IsStillTwoFrames) {
    Line line;
    line.silence(10).send_per_byte(kRead).silence(2.7).send_per_byte(kReadAnswer).silence(50);
    line.send_per_byte(kWrite).silence(2.5).send_per_byte(kWrite);
    Harness h;
    const auto& r = h.run(line.chunks());
    ASSERT_EQ(r.size(), 4U);
    expect_frame(r[0], kRead, Kind::request);
    expect_frame(r[1], kReadAnswer, Kind::response);
    EXPECT_TRUE(r[1].notes.has(note_id::short_gap));
    EXPECT_FALSE(r[0].notes.has(note_id::short_gap));
    expect_frame(r[2], kWrite, Kind::request);
    expect_frame(r[3], kWrite, Kind::response);
    EXPECT_TRUE(r[3].notes.has(note_id::short_gap));
    EXPECT_GT(r[1].latency, 2 * line.char_time());
    EXPECT_LT(r[1].latency, 3 * line.char_time());
}

// Case 3: a junk byte when the driver switches off. `01 03 04 00 00 02` + CRC + 00 also
// passes as a 9-byte FC03 answer with byte count 4; nothing awaits an answer, so it is
// the request, and the 00 is noise.
TEST(Framer, JunkZeroAfterRequestThatAlsoReadsAsAnswer) {
    const Bytes request = with_crc({0x01, 0x03, 0x04, 0x00, 0x00, 0x02});
    const Bytes answer = with_crc({0x01, 0x03, 0x04, 0x00, 0x64, 0x00, 0xC8});
    ASSERT_EQ(check_crc(concat({request, {0x00}})).status, CrcStatus::ok);  // the trap

    Line line;
    line.silence(10).send_per_byte(concat({request, {0x00}})).silence(5);
    line.send_per_byte(concat({answer, {0xFE}})).silence(20);
    Harness h;
    const auto& r = h.run(line.chunks());
    ASSERT_EQ(r.size(), 4U);
    expect_frame(r[0], request, Kind::request);
    expect_noise(r[1], {0x00});
    expect_frame(r[2], answer, Kind::response);
    EXPECT_EQ(r[2].request_number, 1U);
    expect_noise(r[3], {0xFE});
}

// The same bytes when slave 1 owes an answer to a read of 2 registers: the sequence says
// answer, so they are read as the 9-byte answer.
TEST(Framer, SequenceChoosesAnswerReadingWhenAnAnswerIsAwaited) {
    const Bytes ambiguous = concat({with_crc({0x01, 0x03, 0x04, 0x00, 0x00, 0x02}), {0x00}});
    Harness h;
    const auto& r = h.run_raw(concat({kRead, ambiguous}));
    ASSERT_EQ(r.size(), 2U);
    expect_frame(r[0], kRead, Kind::request);
    expect_frame(r[1], ambiguous, Kind::response);
    EXPECT_EQ(r[1].request_number, 1U);
}

// Case 4: garbage before, between and after frames, some of it like a frame header.
TEST(Framer, GarbageAroundFramesBecomesNoise) {
    Line line;
    line.send_chunk({0xFF, 0x13, 0x00}).silence(10);
    line.send_chunk(concat({{0x01, 0x03}, kRead})).silence(4);               // header-like
    line.send_chunk(concat({kReadAnswer, {0x05, 0x06, 0x00}})).silence(10);  // after, header-like
    line.send_chunk(concat({{0x01, 0x03, 0x00}, kWrite})).silence(10);
    line.send_chunk(kWrite).silence(10);
    line.send_chunk({0xAA, 0x55, 0x01});
    Harness h;
    const auto& r = h.run(line.chunks());
    ASSERT_EQ(r.size(), 9U);
    expect_noise(r[0], {0xFF, 0x13, 0x00});
    expect_noise(r[1], {0x01, 0x03});
    expect_frame(r[2], kRead, Kind::request);
    expect_frame(r[3], kReadAnswer, Kind::response);
    expect_noise(r[4], {0x05, 0x06, 0x00});
    expect_noise(r[5], {0x01, 0x03, 0x00});
    expect_frame(r[6], kWrite, Kind::request);
    expect_frame(r[7], kWrite, Kind::response);
    expect_noise(r[8], {0xAA, 0x55, 0x01});
    EXPECT_EQ(h.output_bytes(), h.input_bytes);
}

// Case 5: a transmission broken off, and the frame after it still found.
TEST(Framer, TruncatedFrameThenNextFrameFound) {
    Line line;
    line.silence(10).send_per_byte(kRead).silence(4);
    line.send_per_byte(Bytes(kReadAnswer.begin(), kReadAnswer.begin() + 4)).silence(100);
    line.send_per_byte(kRead).silence(4).send_per_byte(kReadAnswer);
    Harness h;
    const auto& r = h.run(line.chunks());
    ASSERT_EQ(r.size(), 4U);
    expect_frame(r[0], kRead, Kind::request);
    EXPECT_EQ(r[1].kind, Kind::invalid);
    EXPECT_EQ(r[1].frame.bytes, Bytes(kReadAnswer.begin(), kReadAnswer.begin() + 4));
    EXPECT_TRUE(r[1].notes.has(note_id::truncated));
    EXPECT_EQ(r[1].frame.reading, Reading::response);  // the awaited answer, broken off
    EXPECT_EQ(r[1].request_number, 1U);
    EXPECT_FALSE(r[0].notes.has(note_id::no_answer));
    expect_frame(r[2], kRead, Kind::request);
    expect_frame(r[3], kReadAnswer, Kind::response);
    EXPECT_EQ(r[3].request_number, 3U);
}

// Case 6: raw bytes with no timing at all: length and CRC only.
TEST(Framer, RawBytesWithoutTiming) {
    const Bytes exception = with_crc({0x01, 0x83, 0x02});
    const Bytes stream = concat({{0x00},
                                 kRead,
                                 kReadAnswer,
                                 {0x00},
                                 kWriteMany,
                                 kWriteManyAnswer,
                                 {0x12, 0x34},
                                 kRead,
                                 exception,
                                 {0xFE}});
    for (std::size_t chunk : {std::size_t{4096}, std::size_t{1}, std::size_t{5}}) {
        Harness h;
        const auto& r = h.run_raw(stream, chunk);
        ASSERT_EQ(r.size(), 10U) << "chunk size " << chunk;
        expect_noise(r[0], {0x00});
        expect_frame(r[1], kRead, Kind::request);
        expect_frame(r[2], kReadAnswer, Kind::response);
        expect_noise(r[3], {0x00});
        expect_frame(r[4], kWriteMany, Kind::request);
        expect_frame(r[5], kWriteManyAnswer, Kind::response);
        expect_noise(r[6], {0x12, 0x34});
        expect_frame(r[7], kRead, Kind::request);
        expect_frame(r[8], exception, Kind::exception);
        EXPECT_EQ(r[8].request_number, 8U);
        expect_noise(r[9], {0xFE});
        EXPECT_FALSE(has_time(r[1].frame.start));
    }
}

// Case 7: lengths no field gives: FC08 sub-function 0000 echoes any data; vendor codes.
TEST(Framer, UnknownLengthsFoundByCrcBoundedByGaps) {
    const Bytes echo = with_crc({0x04, 0x08, 0x00, 0x00, 0xA5, 0x37, 0x11, 0x22, 0x33});
    const Bytes vendor = with_crc({0x05, 0x41, 0x01, 0x02, 0x03});
    const Bytes vendor_answer = with_crc({0x05, 0x41, 0x10, 0x20, 0x30, 0x40, 0x50, 0x60});
    Line line;
    line.silence(10).send_per_byte(echo).silence(5).send_per_byte(echo).silence(20);
    line.send_per_byte(vendor).silence(5).send_per_byte(vendor_answer).silence(20);
    line.send_per_byte(kRead).silence(5).send_per_byte(kReadAnswer);
    Harness h;
    const auto& r = h.run(line.chunks());
    ASSERT_EQ(r.size(), 6U);
    expect_frame(r[0], echo, Kind::request);
    expect_frame(r[1], echo, Kind::response);
    EXPECT_EQ(r[1].frame.delimiter, Delimiter::crc_search);
    expect_frame(r[2], vendor, Kind::request);
    expect_frame(r[3], vendor_answer, Kind::response);
    EXPECT_EQ(r[3].request_number, 3U);
    expect_frame(r[4], kRead, Kind::request);
    expect_frame(r[5], kReadAnswer, Kind::response);
}

TEST(Framer, UnknownLengthsWithoutTimingStillFound) {
    const Bytes vendor = with_crc({0x05, 0x41, 0x01, 0x02, 0x03});
    Harness h;
    const auto& r = h.run_raw(concat({kRead, kReadAnswer, vendor, kWrite}));
    ASSERT_EQ(r.size(), 4U);
    expect_frame(r[2], vendor, Kind::request);
    expect_frame(r[3], kWrite, Kind::request);
}

// In a raw dump nothing bounds the search for an unknown code's length but the ADU's
// size: here two bytes of noise (slave 0F, code 6B) and a request, followed by the two
// bytes that make the CRC over all of them check, then the answer. The 12 bytes pass
// as a frame followed by another; the request inside says they are one by chance.
TEST(Framer, LengthSearchAcrossARealFrameFindsNone) {
    const Bytes noise = {0x0F, 0x6B};
    const Bytes across = with_crc(concat({noise, kRead}));
    const Bytes chance(across.end() - 2, across.end());
    Harness h;
    const auto& r = h.run_raw(concat({across, kReadAnswer}));
    ASSERT_EQ(r.size(), 4U);
    expect_noise(r[0], noise);
    expect_frame(r[1], kRead, Kind::request);
    expect_noise(r[2], chance);
    expect_frame(r[3], kReadAnswer, Kind::response);
    EXPECT_EQ(r[3].request_number, r[1].number);
}

// The search tries lengths several at a time (framer.cpp): every length must still be
// found, wherever it falls in a step, the shortest first.
TEST(Framer, CrcSearchFindsEveryLength) {
    for (std::size_t length = kMinAdu; length <= 64; ++length) {
        Bytes body = {0x05, 0x41};
        for (std::size_t i = 2; i + 2 < length; ++i) {
            body.push_back(static_cast<std::uint8_t>(i * 37));
        }
        const Bytes vendor = with_crc(body);
        ASSERT_EQ(vendor.size(), length);
        Harness h;
        const auto& r = h.run_raw(concat({kRead, kReadAnswer, vendor, kWrite}));
        ASSERT_EQ(r.size(), 4U) << "length " << length;
        expect_frame(r[2], vendor, Kind::request);
        EXPECT_EQ(r[2].frame.delimiter, Delimiter::crc_search) << "length " << length;
        expect_frame(r[3], kWrite, Kind::request);
        // Last in the input: the search ends with the input, mid-step.
        Harness last;
        const auto& at_end = last.run_raw(concat({kRead, kReadAnswer, vendor}));
        ASSERT_EQ(at_end.size(), 3U) << "length " << length;
        expect_frame(at_end[2], vendor, Kind::request);
    }
}

TEST(Framer, BadCrcBetweenGapsIsInvalidAndSwappedCrcIsAFrame) {
    Bytes corrupt = kRead;
    corrupt[7] ^= 0x40;
    Bytes swapped = kReadAnswer;
    std::swap(swapped[7], swapped[8]);
    Line line;
    line.silence(10).send_per_byte(corrupt).silence(5).send_per_byte(kReadAnswer).silence(20);
    line.send_per_byte(kRead).silence(5).send_per_byte(swapped);
    Harness h;
    const auto& r = h.run(line.chunks());
    ASSERT_EQ(r.size(), 4U);
    EXPECT_EQ(r[0].kind, Kind::invalid);
    EXPECT_EQ(r[0].frame.bytes, corrupt);
    EXPECT_EQ(r[0].frame.crc.status, CrcStatus::bad);
    EXPECT_TRUE(r[0].notes.has(note_id::crc_mismatch));
    // The damage may have happened at the tap: the slave answered, so the pair stands.
    EXPECT_EQ(r[1].kind, Kind::response);
    EXPECT_EQ(r[1].request_number, 1U);
    EXPECT_FALSE(r[0].notes.has(note_id::no_answer));
    EXPECT_EQ(r[3].kind, Kind::response);
    EXPECT_EQ(r[3].frame.crc.status, CrcStatus::swapped);
    EXPECT_EQ(r[3].request_number, 3U);
}

TEST(Framer, BadCrcWithoutTimingIsInvalidWhenTheNextFrameFollowsAtItsLength) {
    Bytes corrupt = kRead;
    corrupt[7] ^= 0x01;
    Harness h;
    const auto& r = h.run_raw(concat({corrupt, kRead, kReadAnswer}));
    ASSERT_EQ(r.size(), 3U);
    EXPECT_EQ(r[0].kind, Kind::invalid);
    EXPECT_EQ(r[0].frame.bytes, corrupt);
}

TEST(Framer, GapInsideAFrameIsNoted) {
    Line line;
    line.silence(10).send_per_byte(Bytes(kRead.begin(), kRead.begin() + 4)).silence(2.5);
    line.send_per_byte(Bytes(kRead.begin() + 4, kRead.end()));
    Harness h;
    const auto& r = h.run(line.chunks());
    ASSERT_EQ(r.size(), 1U);
    expect_frame(r[0], kRead, Kind::request);
    EXPECT_TRUE(r[0].notes.has(note_id::gap_inside));
}

TEST(Framer, WholeFrameChunksAreOneFrameEachRightOrWrong) {
    Bytes bad = kReadAnswer;
    bad[5] ^= 0xFF;
    std::vector<Chunk> lines{{kNoTime, "", kRead, 1, {}, true},
                             {kNoTime, "", bad, 2, {}, true},
                             {kNoTime, "", {0x01, 0x03, 0x00}, 3, {}, true}};
    Harness h;
    const auto& r = h.run(lines);
    ASSERT_EQ(r.size(), 3U);
    expect_frame(r[0], kRead, Kind::request);
    EXPECT_EQ(r[1].kind, Kind::invalid);
    EXPECT_EQ(r[1].frame.crc.status, CrcStatus::bad);
    EXPECT_EQ(r[1].frame.source_line, 2);
    EXPECT_EQ(r[2].kind, Kind::invalid);
}

// A hex log's lines, as the hex reader gives them: stamped when they were seen (the
// first byte's start), whole frames flagged.
Harness hex_log_harness() {
    FramerOptions options;
    options.chunk_time_is_start = true;
    options.chunk_is_line = true;
    return Harness(options);
}

Chunk log_line(Nanos time, Bytes bytes, int line, bool whole = false) {
    return {time, "", std::move(bytes), line, {}, whole};
}

TEST(Framer, AFrameOverSeveralLinesStartsAtItsFirstLinesTime) {
    const Nanos t0 = 36'000 * kNanosPerSecond;
    const std::vector<Chunk> lines{
        log_line(t0, kRead, 1, true),
        log_line(t0 + 20 * kMs, Bytes(kReadAnswer.begin(), kReadAnswer.begin() + 4), 2),
        log_line(t0 + 21 * kMs, Bytes(kReadAnswer.begin() + 4, kReadAnswer.begin() + 5), 3),
        log_line(t0 + 22 * kMs, Bytes(kReadAnswer.begin() + 5, kReadAnswer.end()), 4),
        // A request and its answer on one line: placed back to back from the line's time.
        log_line(t0 + kNanosPerSecond, concat({kRead, kReadAnswer}), 5)};
    Harness h = hex_log_harness();
    const auto& r = h.run(lines);
    ASSERT_EQ(r.size(), 4U);
    expect_frame(r[0], kRead, Kind::request);
    EXPECT_EQ(r[0].frame.start, t0);  // as the log printed it, nothing taken off
    expect_frame(r[1], kReadAnswer, Kind::response);
    EXPECT_EQ(r[1].frame.start, t0 + 20 * kMs);
    EXPECT_EQ(r[1].frame.source_line, 2);
    EXPECT_EQ(r[1].request_number, 1U);
    expect_frame(r[2], kRead, Kind::request);
    EXPECT_EQ(r[2].frame.start, t0 + kNanosPerSecond);
    expect_frame(r[3], kReadAnswer, Kind::response);
    EXPECT_EQ(r[3].frame.start, t0 + kNanosPerSecond + 8 * Line().char_time());
    EXPECT_EQ(r[3].request_number, 3U);
}

// Bytes that form no frame are cut at line starts: a frame with a wrong CRC over two
// lines is one invalid frame, two lines with a wrong CRC each are two, and a line of
// garbage is noise on its own, with or without times.
TEST(Framer, BytesThatFormNoFrameAreCutAtLineStarts) {
    Bytes bad_answer = kReadAnswer;
    bad_answer.back() ^= 0x01;
    Bytes bad_write = kWrite;
    bad_write.back() ^= 0x01;
    for (const bool timed : {false, true}) {
        SCOPED_TRACE(timed ? "timed" : "untimed");
        // Lines 20 ms apart, but for the second half of the answer, 2 ms after the first.
        auto at = [&](int i) { return !timed ? kNoTime : i == 3 ? 42 * kMs : i * 20 * kMs; };
        const std::vector<Chunk> lines{
            log_line(at(1), kRead, 1, true),
            log_line(at(2), Bytes(bad_answer.begin(), bad_answer.begin() + 4), 2),
            log_line(at(3), Bytes(bad_answer.begin() + 4, bad_answer.end()), 3),
            log_line(at(4), bad_write, 4),
            log_line(at(5), bad_write, 5),
            log_line(at(6), {0xAA, 0x00, 0xCC}, 6),
            log_line(at(7), kRead, 7, true)};
        Harness h = hex_log_harness();
        const auto& r = h.run(lines);
        ASSERT_EQ(r.size(), 6U);
        expect_frame(r[0], kRead, Kind::request);
        EXPECT_EQ(r[1].kind, Kind::invalid);
        EXPECT_EQ(r[1].frame.bytes, bad_answer);
        EXPECT_EQ(r[1].frame.crc.status, CrcStatus::bad);
        EXPECT_EQ(r[2].kind, Kind::invalid);
        EXPECT_EQ(r[2].frame.bytes, bad_write);
        EXPECT_EQ(r[2].frame.source_line, 4);
        EXPECT_EQ(r[3].kind, Kind::invalid);
        EXPECT_EQ(r[3].frame.bytes, bad_write);
        EXPECT_EQ(r[3].frame.source_line, 5);
        EXPECT_EQ(r[4].kind, Kind::noise);
        EXPECT_EQ(r[4].frame.bytes, (Bytes{0xAA, 0x00, 0xCC}));
        expect_frame(r[5], kRead, Kind::request);
    }
}

// Every byte of arbitrary input lands in exactly one record, whatever the chunking.
TEST(Framer, EveryByteInExactlyOneRecord) {
    std::uint32_t state = 12345;
    Bytes junk;
    for (int i = 0; i < 5000; ++i) {
        state = state * 1103515245U + 12345U;
        junk.push_back(static_cast<std::uint8_t>(state >> 16));
        if (i % 97 == 0) junk.insert(junk.end(), kRead.begin(), kRead.end());
    }
    for (std::size_t chunk : {std::size_t{1}, std::size_t{7}, std::size_t{4096}}) {
        Harness h;
        h.run_raw(junk, chunk);
        EXPECT_EQ(h.output_bytes(), junk.size()) << "chunk size " << chunk;
        for (std::size_t i = 1; i < h.records.size(); ++i) {
            EXPECT_EQ(h.records[i].number, h.records[i - 1].number + 1);
        }
    }
}

// Large USB batches: the framer keeps each chunk's timing once (not per byte) and drops
// decided bytes as it goes, so times and input lines must come out right across many
// chunks and across the points where the buffer is compacted (every 64 KiB).
TEST(Framer, TimesAndLinesStayRightAcrossLargeChunksAndBufferCompaction) {
    constexpr std::size_t kFrames = 20000;  // 160 000 bytes
    Bytes all;
    for (std::size_t i = 0; i < kFrames; ++i) all.insert(all.end(), kRead.begin(), kRead.end());
    const Nanos ch = Line().char_time();
    // Back to back, handed over 7001 and 3 bytes at a time (frames straddle chunks),
    // each chunk timed at its last byte's end and numbered as a line of its own.
    std::vector<Chunk> chunks;
    std::vector<int> line_of_byte;
    std::size_t n = 0;
    for (std::size_t at = 0; at < all.size(); at += n) {
        n = n == 7001 ? 3 : 7001;
        const std::size_t end = std::min(all.size(), at + n);
        const int line = static_cast<int>(chunks.size()) + 1;
        chunks.push_back({static_cast<Nanos>(end) * ch,
                          "",
                          Bytes(all.begin() + static_cast<std::ptrdiff_t>(at),
                                all.begin() + static_cast<std::ptrdiff_t>(end)),
                          line,
                          {}});
        line_of_byte.insert(line_of_byte.end(), end - at, line);
    }
    Harness h;
    const auto& r = h.run(chunks);
    ASSERT_EQ(r.size(), kFrames);
    for (std::size_t i = 0; i < kFrames; ++i) {
        const std::size_t first = i * kRead.size();
        ASSERT_EQ(r[i].frame.bytes, kRead) << "record " << i;
        ASSERT_EQ(r[i].frame.start, static_cast<Nanos>(first) * ch) << "record " << i;
        ASSERT_EQ(r[i].frame.end, static_cast<Nanos>(first + kRead.size()) * ch) << "record " << i;
        ASSERT_EQ(r[i].frame.source_line, line_of_byte[first]) << "record " << i;
    }
}

// A chunk handed over sooner than its bytes could have come (the adapter held the first
// frame back): its bytes are spread evenly from the end of the previous chunk to its
// own time, each byte ending at first + span * (k + 1) / n, in whole nanoseconds.
TEST(Framer, BytesOfALateChunkAreSpreadEvenlyToTheNanosecond) {
    const Nanos ch = Line().char_time();
    const Nanos first_time = kNanosPerSecond;
    const Nanos span = 1'000'003;  // far less than 17 characters take, and not a multiple of 17
    Bytes both = kRead;
    both.insert(both.end(), kReadAnswer.begin(), kReadAnswer.end());
    const auto n = static_cast<Nanos>(both.size());
    auto byte_end = [&](Nanos k) { return first_time + span * (k + 1) / n; };

    Harness h;
    const auto& r = h.run({{first_time, "", kRead, 1, {}}, {first_time + span, "", both, 2, {}}});
    ASSERT_EQ(r.size(), 3U);
    expect_frame(r[1], kRead, Kind::request);
    expect_frame(r[2], kReadAnswer, Kind::response);
    EXPECT_EQ(r[1].frame.start, byte_end(0) - ch);
    EXPECT_EQ(r[1].frame.end, byte_end(7));
    EXPECT_EQ(r[2].frame.start, byte_end(8) - ch);
    EXPECT_EQ(r[2].frame.end, first_time + span);
}

// On a two-port tap the port decides how a frame cut short is read, as any other: 5 bytes
// on the slaves' port, no request awaited, are an answer cut short (◀), measured against
// an answer's length, not a request's.
TEST(Framer, ACutShortFrameGoesTheWayItsPortSays) {
    const Nanos t = 1'000'000'000;
    std::vector<Chunk> chunks{{t, "slave", {0x01, 0x03, 0x04, 0x00, 0x01}, 1, {}, false},
                              {t + 50 * kMs, "master", {0x01, 0x03, 0x04, 0x00, 0x01}, 2, {}, false}};
    Harness h;
    const auto& r = h.run(chunks);
    ASSERT_EQ(r.size(), 2U);
    EXPECT_EQ(r[0].kind, Kind::invalid);
    EXPECT_EQ(r[0].frame.reading, Reading::response);
    // Cut short by the answer's length (4 registers' worth: 9 bytes), not the request's (8).
    const auto cut = std::find_if(r[0].notes.begin(), r[0].notes.end(),
                                  [](const Note& n) { return std::string_view(n.id) == note_id::truncated; });
    ASSERT_NE(cut, r[0].notes.end());
    EXPECT_EQ(cut->text, "cut short: 5 of 9 bytes");
    EXPECT_EQ(r[1].frame.reading, Reading::request);
}

// A crafted capture naming a new channel on every line: each frame keeps its own channel,
// however many came before it, and the names are not kept for ever: the framer holds only
// those of the chunks it buffers, so such a capture decodes as quickly as any other.
TEST(Framer, ChannelsBeyondTheFirst65536KeepTheirNames) {
    std::vector<Chunk> chunks;
    for (int i = 0; i < 70'000; ++i) {
        Chunk c;
        c.time = Nanos{1'000'000'000} + i * 10 * kMs;
        c.channel = "ch" + std::to_string(i);
        c.bytes = kRead;
        chunks.push_back(std::move(c));
    }
    Harness h;
    const auto& r = h.run(chunks);
    ASSERT_EQ(r.size(), 70'000U);
    for (std::size_t i = 0; i < r.size(); i += 997) {
        EXPECT_EQ(r[i].frame.channel, "ch" + std::to_string(i));
        EXPECT_EQ(r[i].frame.bytes, kRead);
    }
    EXPECT_EQ(r.back().frame.channel, "ch69999");
}

// UART errors and clock jumps are listed by their place in the framer's buffer, which
// moves whenever it drops what it has decided: every 64 KiB of frames, every 4,096 chunks
// of garbage it cannot decide yet. Through streams long enough for both, each must still be
// noted on the record that holds its byte, at that byte (the first and the last of a frame
// included).
class MarksOnLongStreams : public ::testing::TestWithParam<std::vector<std::size_t>> {};

TEST_P(MarksOnLongStreams, EachOnTheRecordAndByteItHit) {
    // Garbage with reads in it, handed over in chunks of the sizes given, in turn.
    Bytes all;
    std::uint32_t state = 99;
    while (all.size() < 200'000) {
        state = state * 1103515245U + 12345U;
        if (state % 50 == 0) {
            all.insert(all.end(), kRead.begin(), kRead.end());
        } else {
            all.push_back(static_cast<std::uint8_t>(state >> 16));
        }
    }
    const Nanos ch = Line().char_time();
    std::vector<Chunk> chunks;
    std::set<std::size_t> errors;                   // every 7th byte
    std::map<std::size_t, std::string> jump_notes;  // by the first byte after the jump
    Nanos clock = 1000 * kNanosPerSecond;
    std::size_t n = 0;
    for (std::size_t at = 0; at < all.size(); at += n) {
        const std::vector<std::size_t>& sizes = GetParam();
        n = std::min(sizes[chunks.size() % sizes.size()], all.size() - at);
        Chunk c;
        c.bytes.assign(all.begin() + static_cast<std::ptrdiff_t>(at),
                       all.begin() + static_cast<std::ptrdiff_t>(at + n));
        for (std::size_t i = at; i < at + n; ++i) {
            if (i % 7 == 3) {
                errors.insert(i);
                c.char_errors.push_back(static_cast<std::uint32_t>(i - at));
            }
        }
        if (chunks.size() % 97 == 50) {
            // This chunk's last byte ends before the chunk before it ended.
            const Nanos back = kNanosPerSecond + static_cast<Nanos>(chunks.size()) * kMs;
            clock -= back;
            jump_notes[at] = fmt::format("the input's time goes back {:.3f} s here",
                                         static_cast<double>(back) / 1e9);
        } else {
            clock += static_cast<Nanos>(n) * ch;
        }
        c.time = clock;
        chunks.push_back(std::move(c));
    }

    std::vector<Frame> records;
    Framer framer(FramerOptions{}, [&](const Frame& f) { records.push_back(f); });
    for (const Chunk& c : chunks) framer.push(c);
    framer.finish();

    std::set<std::size_t> noted_errors;
    // By the record's first byte: a frame whose CRC checks may hold a jump, or two.
    std::map<std::size_t, std::vector<std::string>> noted_jumps;
    std::size_t first = 0;
    for (const Frame& r : records) {
        for (const Note& note : r.notes) {
            if (note.id == std::string_view(note_id::char_error)) {
                const std::string_view prefix = "parity/framing error on byte ";
                ASSERT_TRUE(note.text.starts_with(prefix)) << note.text;
                std::istringstream list(note.text.substr(prefix.size()));
                std::string item;
                while (std::getline(list, item, ',')) {
                    noted_errors.insert(first + std::stoul(item) - 1);
                }
            } else if (note.id == std::string_view(note_id::time_backwards)) {
                noted_jumps[first].push_back(note.text);
            }
        }
        first += r.bytes.size();
    }
    ASSERT_EQ(first, all.size());
    EXPECT_EQ(noted_errors, errors);
    // Each jump on the record that holds the byte after it.
    std::map<std::size_t, std::vector<std::string>> expected_jumps;
    std::size_t record_first = 0;
    auto record = records.begin();
    for (const auto& [at, text] : jump_notes) {
        while (record_first + record->bytes.size() <= at) record_first += (record++)->bytes.size();
        expected_jumps[record_first].push_back(text);
    }
    EXPECT_EQ(noted_jumps, expected_jumps);
    EXPECT_GT(jump_notes.size(), 2U);
}

// Large batches (the buffer is dropped every 64 KiB), and one byte at a time (garbage is
// dropped every 4,096 chunks with the bytes after the undecided position kept).
INSTANTIATE_TEST_SUITE_P(Framer, MarksOnLongStreams,
                         ::testing::Values(std::vector<std::size_t>{1999, 3, 61, 5},
                                           std::vector<std::size_t>{1}));

}  // namespace
}  // namespace rtuscope

namespace rtuscope {
namespace {

// Register data that happens to hold a valid CRC of the bytes before it must not end the
// frame there (a known failure of sniffers that end a frame at the first CRC that checks):
// here an FC03 answer whose third and fourth registers are the CRC of its first seven
// bytes. Its byte count says 13 bytes, whether the bytes come one at a time, all at once
// or with no timing at all.
TEST(Framer, ACrcInsideTheRegisterDataDoesNotEndTheFrame) {
    const Bytes read4 = test::with_crc({0x01, 0x03, 0x00, 0x00, 0x00, 0x04});
    const Bytes head = {0x01, 0x03, 0x08, 0x12, 0x34, 0x56, 0x78};
    const Bytes inner = test::with_crc(head);    // the head and its CRC: 9 bytes that check
    Bytes data(inner.begin() + 3, inner.end());  // 6 data bytes, the CRC among them
    data.push_back(0x9A);
    data.push_back(0xBC);
    const Bytes answer = test::with_crc(concat({{0x01, 0x03, 0x08}, data}));
    ASSERT_EQ(answer.size(), 13U);
    ASSERT_TRUE(std::equal(inner.begin(), inner.end(), answer.begin()));  // the trap is set

    for (const int delivery : {0, 1, 2}) {
        SCOPED_TRACE(delivery == 0 ? "one byte a chunk" : delivery == 1 ? "one chunk" : "raw");
        Line line;
        line.silence(10);
        if (delivery == 0) line.send_per_byte(read4).silence(4).send_per_byte(answer);
        if (delivery == 1) line.send_chunk(read4).silence(4).send_chunk(answer);
        Harness h;
        const auto& r = delivery == 2 ? h.run_raw(concat({read4, answer})) : h.run(line.chunks());
        ASSERT_EQ(r.size(), 2U);
        expect_frame(r[0], read4, Kind::request);
        expect_frame(r[1], answer, Kind::response);
        EXPECT_EQ(r[1].request_number, r[0].number);
    }
}

}  // namespace
}  // namespace rtuscope
