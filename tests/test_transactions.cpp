// Pairing: requests with their answers, turnaround, exceptions, broadcasts, requests
// without answer, answers without request, echoes told apart by order and timing.
#include <gtest/gtest.h>

#include <set>

#include "framing/framer.hpp"
#include "pairing/transactions.hpp"
#include "support.hpp"

namespace rtuscope {
namespace {

using test::Bytes;
using test::Harness;
using test::kMs;
using test::Line;
using test::with_crc;

const Bytes kRead = with_crc({0x01, 0x03, 0x00, 0x00, 0x00, 0x02});
const Bytes kReadAnswer = with_crc({0x01, 0x03, 0x04, 0x17, 0xF8, 0x00, 0x2A});
const Bytes kWrite = with_crc({0x02, 0x06, 0x00, 0x01, 0x00, 0x03});

TEST(Transactions, PairsAnswerAndMeasuresTurnaround) {
    Line line;
    line.silence(10).send_per_byte(kRead).silence_ms(19.5).send_per_byte(kReadAnswer);
    Harness h;
    const auto& r = h.run(line.chunks());
    ASSERT_EQ(r.size(), 2U);
    EXPECT_EQ(r[0].kind, Kind::request);
    EXPECT_EQ(r[1].kind, Kind::response);
    EXPECT_EQ(r[1].request_number, r[0].number);
    EXPECT_EQ(r[1].request, kRead);
    EXPECT_NEAR(static_cast<double>(r[1].latency) / 1e6, 19.5, 0.01);
}

TEST(Transactions, SecondAnswerToOneRequestPointsAtADuplicateAddress) {
    Line line;
    line.silence(10).send_per_byte(kRead).silence(5).send_per_byte(kReadAnswer);
    line.silence(5).send_per_byte(kReadAnswer).silence(50).send_per_byte(kRead);
    line.silence(5).send_per_byte(kReadAnswer);
    Harness h;
    const auto& r = h.run(line.chunks());
    ASSERT_EQ(r.size(), 5U);
    EXPECT_EQ(r[1].request_number, 1U);
    EXPECT_FALSE(r[1].notes.has(note_id::duplicate_answer));
    EXPECT_EQ(r[2].kind, Kind::response);
    ASSERT_TRUE(r[2].notes.has(note_id::duplicate_answer));
    EXPECT_EQ(r[2].notes.back().text, "second answer to #1 (after #2): two devices on address 1?");
    EXPECT_FALSE(r[2].notes.has(note_id::unsolicited));
    // A new request starts afresh: its one answer is no duplicate.
    EXPECT_EQ(r[4].request_number, 4U);
    EXPECT_FALSE(r[4].notes.has(note_id::duplicate_answer));
}

TEST(Transactions, ExceptionPairsWithItsRequest) {
    const Bytes exception = with_crc({0x01, 0x83, 0x02});
    Line line;
    line.silence(10).send_per_byte(kRead).silence(5).send_per_byte(exception);
    Harness h;
    const auto& r = h.run(line.chunks());
    ASSERT_EQ(r.size(), 2U);
    EXPECT_EQ(r[1].kind, Kind::exception);
    EXPECT_EQ(r[1].request_number, 1U);
}

TEST(Transactions, NoAnswerWithinTimeout) {
    Line line;
    line.silence(10).send_per_byte(kRead).silence_ms(1500).send_per_byte(kReadAnswer);
    Harness h;
    const auto& r = h.run(line.chunks());
    ASSERT_EQ(r.size(), 2U);
    EXPECT_TRUE(r[0].notes.has(note_id::no_answer));
    EXPECT_EQ(r[0].notes.back().text, "no answer within 1 s");
    EXPECT_EQ(r[1].kind, Kind::response);
    EXPECT_EQ(r[1].request_number, 0U);
    EXPECT_TRUE(r[1].notes.has(note_id::unsolicited));
}

TEST(Transactions, NextRequestEndsTheWaitAndOrderIsKept) {
    const Bytes other = with_crc({0x07, 0x03, 0x00, 0x00, 0x00, 0x01});
    Line line;
    line.silence(10).send_per_byte(other).silence(50).send_chunk({0xEE}).silence(50);
    line.send_per_byte(kRead).silence(5).send_per_byte(kReadAnswer);
    Harness h;
    const auto& r = h.run(line.chunks());
    ASSERT_EQ(r.size(), 4U);
    EXPECT_EQ(r[0].frame.bytes, other);
    EXPECT_TRUE(r[0].notes.has(note_id::no_answer));
    EXPECT_EQ(r[1].kind, Kind::noise);
    EXPECT_EQ(r[2].number, 3U);
    EXPECT_EQ(r[3].request_number, 3U);
    EXPECT_FALSE(r[2].notes.has(note_id::no_answer));
}

TEST(Transactions, UnansweredAtEndOfInput) {
    Harness h;
    const auto& r = h.run_raw(kRead);
    ASSERT_EQ(r.size(), 1U);
    EXPECT_TRUE(r[0].notes.has(note_id::no_answer));
}

TEST(Transactions, BroadcastExpectsNoAnswer) {
    const Bytes broadcast = with_crc({0x00, 0x06, 0x00, 0x01, 0x00, 0x05});
    Line line;
    line.silence(10).send_per_byte(broadcast).silence(100).send_per_byte(kRead);
    line.silence(5).send_per_byte(kReadAnswer);
    Harness h;
    const auto& r = h.run(line.chunks());
    ASSERT_EQ(r.size(), 3U);
    EXPECT_EQ(r[0].kind, Kind::broadcast);
    EXPECT_FALSE(r[0].notes.has(note_id::no_answer));
    EXPECT_EQ(r[2].request_number, 2U);
}

TEST(Transactions, EchoesToldApartByOrder) {
    // Write single register: the answer is byte for byte the request.
    Line line;
    line.silence(10).send_per_byte(kWrite).silence(5).send_per_byte(kWrite).silence(100);
    line.send_per_byte(kWrite).silence(5).send_per_byte(kWrite);
    Harness h;
    const auto& r = h.run(line.chunks());
    ASSERT_EQ(r.size(), 4U);
    EXPECT_EQ(r[0].kind, Kind::request);
    EXPECT_EQ(r[1].kind, Kind::response);
    EXPECT_EQ(r[2].kind, Kind::request);
    EXPECT_EQ(r[3].kind, Kind::response);
    EXPECT_EQ(r[3].request_number, 3U);
}

TEST(Transactions, EchoAfterTimeoutIsANewRequest) {
    Line line;
    line.silence(10).send_per_byte(kWrite).silence_ms(1200).send_per_byte(kWrite);
    Harness h;
    const auto& r = h.run(line.chunks());
    ASSERT_EQ(r.size(), 2U);
    EXPECT_EQ(r[0].kind, Kind::request);
    EXPECT_TRUE(r[0].notes.has(note_id::no_answer));
    EXPECT_EQ(r[1].kind, Kind::request);
}

TEST(Transactions, RetryOfTheSameReadIsARequest) {
    Line line;
    line.silence(10).send_per_byte(kRead).silence_ms(300).send_per_byte(kRead);
    line.silence(5).send_per_byte(kReadAnswer);
    Harness h;
    const auto& r = h.run(line.chunks());
    ASSERT_EQ(r.size(), 3U);
    EXPECT_EQ(r[1].kind, Kind::request);
    EXPECT_TRUE(r[0].notes.has(note_id::no_answer));
    EXPECT_EQ(r[2].request_number, 2U);
}

TEST(Transactions, AnswerFromAnotherSlaveIsUnsolicited) {
    const Bytes stray = with_crc({0x09, 0x03, 0x02, 0x00, 0x01});
    Harness h;
    const auto& r = h.run_raw(test::concat({stray, kRead, kReadAnswer}));
    ASSERT_EQ(r.size(), 3U);
    EXPECT_EQ(r[0].kind, Kind::response);
    EXPECT_TRUE(r[0].notes.has(note_id::unsolicited));
    EXPECT_EQ(r[2].request_number, 2U);
}

// The records of `chunks`, and how many frames behind the newest each was emitted, at most.
struct Emitted {
    std::vector<Record> records;
    std::uint64_t held_most = 0;
};
Emitted run_counting_held(const std::vector<Chunk>& chunks) {
    Emitted out;
    std::uint64_t pushed = 0;
    Transactions transactions({kNanosPerSecond, &standard_rules()}, [&](Record&& record) {
        out.held_most = std::max(out.held_most, pushed - record.number);
        out.records.push_back(std::move(record));
    });
    FramerOptions options;
    options.expectation = &transactions;
    Framer framer(options, [&](Frame& f) {
        ++pushed;
        transactions.push(f);
    });
    for (const Chunk& chunk : chunks) framer.push(chunk);
    framer.finish();
    transactions.finish();
    return out;
}

// A raw dump (no times to time out by): a request, then only another slave's answers, ten
// more than can be held behind it.
Chunk longest_wait() {
    const Bytes other = with_crc({0x02, 0x03, 0x02, 0x00, 0x01});
    Chunk dump;
    dump.bytes = kRead;
    for (std::size_t i = 0; i < kMaxFramesAwaiting + 10; ++i) {
        dump.bytes.insert(dump.bytes.end(), other.begin(), other.end());
    }
    return dump;
}

TEST(Transactions, NoAnswerWithinTheMostFramesHeldBehindARequest) {
    Chunk dump = longest_wait();
    dump.bytes.insert(dump.bytes.end(), kReadAnswer.begin(), kReadAnswer.end());
    const Emitted e = run_counting_held({dump});
    const std::vector<Record>& r = e.records;
    ASSERT_EQ(r.size(), kMaxFramesAwaiting + 12);
    ASSERT_TRUE(r[0].notes.has(note_id::no_answer));
    EXPECT_EQ(r[0].notes.back().text, "no answer within 4096 frames");
    EXPECT_LE(e.held_most, kMaxFramesAwaiting + 1);
    EXPECT_EQ(r.back().kind, Kind::response);
    EXPECT_EQ(r.back().request_number, 0U);  // too late for its request
    EXPECT_TRUE(r.back().notes.has(note_id::unsolicited));
}

TEST(Transactions, NoAnswerWithinTheMostBytesHeldBehindARequest) {
    // Frames that stand alone (as a pcap's packets), no times: a request, then frames of
    // 300,000 bytes.
    std::vector<Chunk> lines(1);
    lines[0].bytes = kRead;
    for (int i = 0; i < 6; ++i) {
        Chunk big;
        big.bytes.assign(300'000, 0x00);
        big.bytes[0] = 0x02;
        big.bytes[1] = 0x03;
        lines.push_back(std::move(big));
    }
    for (Chunk& line : lines) line.whole_frame = true;
    const Emitted e = run_counting_held(lines);
    const std::vector<Record>& r = e.records;
    ASSERT_EQ(r.size(), 7U);
    ASSERT_TRUE(r[0].notes.has(note_id::no_answer));
    EXPECT_EQ(r[0].notes.back().text, "no answer within 1048576 bytes");
    EXPECT_EQ(e.held_most, 4U);  // given up once the fourth passed 1 MiB
}

// Frames a raw dump (no times) and pairs its frames, handing each record to `emit`.
void pair_raw_dump(const Chunk& dump, const Transactions::Emit& emit) {
    Transactions transactions({kNanosPerSecond, &standard_rules()}, emit);
    FramerOptions options;
    options.expectation = &transactions;
    Framer framer(options, [&](Frame& f) { transactions.push(f); });
    framer.push(dump);
    framer.finish();
    transactions.finish();
}

// The records that follow the longest wait, and the slots they were emitted from.
struct AfterTheWait {
    std::vector<Record> records;
    std::set<const Record*> slots;
};

AfterTheWait after_the_longest_wait(const Bytes& traffic) {
    Chunk dump = longest_wait();
    dump.bytes.insert(dump.bytes.end(), traffic.begin(), traffic.end());
    constexpr std::uint64_t kFirstAfterTheWait = kMaxFramesAwaiting + 12;
    AfterTheWait after;
    pair_raw_dump(dump, [&](Record&& record) {
        if (record.number < kFirstAfterTheWait) return;
        after.slots.insert(&record);
        after.records.push_back(record);
    });
    return after;
}

Bytes repeated(const std::vector<Bytes>& frames, int times) {
    Bytes out;
    for (int i = 0; i < times; ++i) {
        for (const Bytes& frame : frames) out.insert(out.end(), frame.begin(), frame.end());
    }
    return out;
}

// A long wait grows the slots of held records to thousands. The traffic after it must go
// back to a few: going through all of them, it would leave each one holding the buffers of
// the largest record it carried (with a profile, ~500 KB for a 2,000-coil read: gigabytes
// over thousands of slots).
TEST(Transactions, AfterALongWaitRecordsReuseTheFirstSlotsAgain) {
    constexpr int kPolls = 1000;
    const AfterTheWait after = after_the_longest_wait(repeated({kRead, kReadAnswer}, kPolls));
    ASSERT_EQ(after.records.size(), 2U * kPolls);
    for (std::size_t i = 1; i < after.records.size(); i += 2) {
        EXPECT_EQ(after.records[i].kind, Kind::response);
        EXPECT_EQ(after.records[i].request_number + 1, after.records[i].number);
    }
    EXPECT_LE(after.slots.size(), 2U);
}

// Unanswered requests each hold only themselves until the next one comes, so something
// is always held: they too must reuse the first slots, not step through every slot the
// wait has grown (with large writes decoded with a profile, each would keep ~500 KB).
TEST(Transactions, AfterALongWaitUnansweredRequestsReuseTheFirstSlotsToo) {
    constexpr int kRetries = 1000;
    const Bytes other_read = with_crc({0x03, 0x03, 0x00, 0x10, 0x00, 0x01});
    const AfterTheWait after = after_the_longest_wait(repeated({kRead, other_read}, kRetries));
    ASSERT_EQ(after.records.size(), 2U * kRetries);
    for (const Record& r : after.records) {
        EXPECT_EQ(r.kind, Kind::request);
        EXPECT_TRUE(r.notes.has(note_id::no_answer));
    }
    EXPECT_LE(after.slots.size(), 2U);
}

// The decoder fills each record where it is held, so a slot that keeps its buffers keeps
// what the largest record it carried was decoded into (with a profile, ~500 KB of values
// for a 2,000-coil write). Only the first few slots, those ordinary traffic uses, may keep
// them: after a wait, the others give everything back.
TEST(Transactions, SlotsAWaitReachedGiveTheirDecodedBuffersBack) {
    Chunk dump = longest_wait();
    const Chunk second_wait = longest_wait();
    dump.bytes.insert(dump.bytes.end(), second_wait.bytes.begin(), second_wait.bytes.end());
    const std::uint64_t first_of_second_wait = kMaxFramesAwaiting + 12;
    constexpr std::size_t kDecoded = 2048;    // below what even the first slots give back
    std::set<const Record*> slots_with_room;  // in the second wait
    std::uint64_t emitted = 0;
    pair_raw_dump(dump, [&](Record&& record) {
        ++emitted;
        if (record.number < first_of_second_wait) {
            record.decoded.summary.reserve(kDecoded);  // as decoding a large record would
        } else if (record.decoded.summary.capacity() >= kDecoded) {
            slots_with_room.insert(&record);
        }
    });
    ASSERT_EQ(emitted, 2 * first_of_second_wait - 2);
    EXPECT_LE(slots_with_room.size(), 4U);
}

// Nor do the first slots keep the summary of a huge frame: a hex line or pcap packet of a
// function rtuscope does not know is summed up in three characters a byte.
TEST(Transactions, NoSlotKeepsTheSummaryOfAHugeFrame) {
    constexpr std::size_t kHugeSummary = 3 * 256 * 1024;
    Chunk polls;
    polls.bytes = repeated({kRead, kReadAnswer}, 100);
    std::size_t arrived_with_room = 0;
    pair_raw_dump(polls, [&](Record&& record) {
        if (record.decoded.summary.capacity() >= kHugeSummary) ++arrived_with_room;
        record.decoded.summary.reserve(kHugeSummary);
    });
    EXPECT_EQ(arrived_with_room, 0U);
}

// Records wait while a request does (they must leave in stream order) and are reused
// once emitted: many records held at once must keep their order and contents, and the
// awaited request its bytes.
TEST(Transactions, ManyRecordsHeldBehindAnAwaitedRequestKeepOrderAndContents) {
    constexpr std::size_t kNoiseRuns = 100;
    Line line;
    line.silence(10).send_per_byte(kRead);
    for (std::size_t i = 0; i < kNoiseRuns; ++i) {
        line.silence(5).send_per_byte({static_cast<std::uint8_t>(i), 0xFF});
    }
    line.silence(5).send_per_byte(kReadAnswer).silence(5).send_per_byte(kWrite);
    Harness h;
    const auto& r = h.run(line.chunks());
    ASSERT_EQ(r.size(), kNoiseRuns + 3);
    for (std::size_t i = 0; i < r.size(); ++i) EXPECT_EQ(r[i].number, i + 1);
    EXPECT_EQ(r[0].kind, Kind::request);
    EXPECT_EQ(r[0].frame.bytes, kRead);
    for (std::size_t i = 0; i < kNoiseRuns; ++i) {
        EXPECT_EQ(r[i + 1].kind, Kind::noise);
        EXPECT_EQ(r[i + 1].frame.bytes, Bytes({static_cast<std::uint8_t>(i), 0xFF}));
    }
    EXPECT_EQ(r[kNoiseRuns + 1].kind, Kind::response);
    EXPECT_EQ(r[kNoiseRuns + 1].request_number, 1U);
    EXPECT_EQ(r[kNoiseRuns + 1].request, kRead);
    EXPECT_EQ(r[kNoiseRuns + 2].kind, Kind::request);
    EXPECT_EQ(r[kNoiseRuns + 2].frame.bytes, kWrite);
}

}  // namespace
}  // namespace rtuscope

namespace rtuscope {
namespace {

// One frame a chunk, as a pcap packet delivers it: an answer cut short
// has no shape to tell its direction, but it stands where the awaited answer would, so it
// is that answer, broken, and the request is answered (by a broken answer), not left
// without one.
TEST(Transactions, ACutShortAnswerInItsOwnLineAnswersTheRequestBeforeIt) {
    Harness h;
    Chunk request;
    request.bytes = kRead;
    request.whole_frame = true;
    Chunk cut;
    cut.bytes = {0x01, 0x03, 0x04, 0x17};
    cut.whole_frame = true;
    const auto& r = h.run({request, cut});
    ASSERT_EQ(r.size(), 2U);
    EXPECT_EQ(r[0].kind, Kind::request);
    EXPECT_FALSE(r[0].notes.has(note_id::no_answer));
    EXPECT_EQ(r[1].kind, Kind::invalid);
    EXPECT_EQ(r[1].request_number, r[0].number);
}

// A broken frame of another slave is no answer to the request.
TEST(Transactions, ABrokenFrameOfAnotherSlaveAnswersNothing) {
    Harness h;
    Chunk request;
    request.bytes = kRead;
    request.whole_frame = true;
    Chunk other;
    other.bytes = {0x07, 0x03, 0x04, 0x17};
    other.whole_frame = true;
    const auto& r = h.run({request, other});
    ASSERT_EQ(r.size(), 2U);
    EXPECT_TRUE(r[0].notes.has(note_id::no_answer));
    EXPECT_EQ(r[1].request_number, 0U);
}

}  // namespace
}  // namespace rtuscope
