// The benchmarks' traffic (bench/traffic.hpp), decoded: what the generator put on the line
// must come out of the pipeline frame for frame. This checks the generator, on whose
// traffic the benchmarks' figures are measured, and the framer and pairing on a hundred
// thousand frames of the four seed devices and standard devices, with USB batching,
// damaged frames, junk and noise, at two speeds, as a native capture and as a raw dump, and
// as a capture of one byte a line. A second test checks the traffic's mix itself.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdlib>
#include <map>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

#include "input/capture_writer.hpp"
#include "input/sources.hpp"
#include "pipeline.hpp"
#include "profiles/bus.hpp"
#include "support.hpp"
#include "traffic.hpp"

namespace rtuscope {
namespace {

using bench::SentFrame;

// The traffic, and what the generator says it sent.
struct Generated {
    bench::TrafficInMemory traffic;
    std::vector<SentFrame> sent;
};

// RTUSCOPE_SEED=N in the environment generates another seed's traffic: the tests must
// pass on any seed, not on the default one by luck.
Generated generate(std::uint64_t frames, std::uint32_t baud, bool per_byte) {
    Generated g;
    const char* seed_env = std::getenv("RTUSCOPE_SEED");
    const std::uint64_t seed = seed_env != nullptr ? std::strtoull(seed_env, nullptr, 10) : 1;
    g.traffic = bench::traffic_in_memory(
        {.frames = frames, .seed = seed, .baud = baud, .per_byte = per_byte},
        [&](const SentFrame& s) { g.sent.push_back(s); });
    return g;
}

// One poll as the generator sent it: a request and the answer, if one came back.
struct Poll {
    const SentFrame* request = nullptr;
    const SentFrame* answer = nullptr;

    [[nodiscard]] bool damaged() const {
        return request->damaged || (answer != nullptr && answer->damaged);
    }
    [[nodiscard]] bool broadcast() const { return request->bytes[0] == 0; }
    // Left waiting for its answer, or with a frame the tap saw damaged.
    [[nodiscard]] bool open() const { return damaged() || (answer == nullptr && !broadcast()); }
    // The slave and function the master asked. A damaged request may have its flipped bit
    // there, so an intact answer's (an exception's without the 0x80) is taken instead.
    [[nodiscard]] std::pair<std::uint8_t, std::uint8_t> key() const {
        const SentFrame* frame =
            request->damaged && answer != nullptr && !answer->damaged ? answer : request;
        return {frame->bytes[0], static_cast<std::uint8_t>(frame->bytes[1] & 0x7FU)};
    }
    // Whether it may have left `k`'s slave and function waiting: it meant them, or one of
    // its frames reads as theirs, a damaged one from any of its bytes (the framer may
    // resynchronise there).
    [[nodiscard]] bool touches(std::pair<std::uint8_t, std::uint8_t> k) const {
        auto reads_as = [&](const SentFrame* frame) {
            if (frame == nullptr) return false;
            const std::size_t starts = frame->damaged ? frame->bytes.size() - 1 : 1;
            for (std::size_t i = 0; i < starts; ++i) {
                if (frame->bytes[i] == k.first && (frame->bytes[i + 1] & 0x7FU) == k.second) {
                    return true;
                }
            }
            return false;
        };
        return key() == k || reads_as(request) || reads_as(answer);
    }
    // Answered with the request's own bytes (FC05, FC06): order alone tells which is which.
    [[nodiscard]] bool answered_by_echo() const {
        return answer != nullptr && answer->bytes == request->bytes;
    }
};

std::vector<Poll> polls_of(const std::vector<SentFrame>& sent) {
    std::vector<Poll> polls;
    for (const SentFrame& s : sent) {
        if (s.what == SentFrame::What::request) polls.push_back({&s});
        if (s.what == SentFrame::What::answer) polls.back().answer = &s;
    }
    return polls;
}

struct Case {
    std::uint32_t baud;
    InputFormat format;
    bool per_byte = false;
};

std::string name_of(const Case& c) {
    return fmt::format("{}_{}{}", c.format == InputFormat::raw ? "raw" : "capture", c.baud,
                       c.per_byte ? "_per_byte" : "");
}

// For gtest's messages and ctest's test list (its bytes otherwise).
void PrintTo(const Case& c, std::ostream* out) {
    *out << name_of(c);
}

class BenchTraffic : public ::testing::TestWithParam<Case> {};

TEST_P(BenchTraffic, DecodesToWhatWasSent) {
    const Case c = GetParam();
    const Generated g = generate(100'000, c.baud, c.per_byte);
    Bus bus;
    ASSERT_TRUE(test::assign_seed_devices(bus));
    PipelineOptions options;
    options.bus = &bus;
    auto source = source_from_memory(
        c.format == InputFormat::raw ? g.traffic.raw : g.traffic.capture, "traffic", c.format);
    ASSERT_TRUE(source);
    test::CollectingSink sink;
    ASSERT_TRUE(run_pipeline(**source, options, sink));
    const std::vector<Record>& records = sink.records;

    // Every byte is in exactly one record, in order.
    std::string all;
    for (std::size_t i = 0; i < records.size(); ++i) {
        ASSERT_EQ(records[i].number, i + 1);
        all.append(records[i].frame.bytes.begin(), records[i].frame.bytes.end());
    }
    ASSERT_EQ(all.size(), g.traffic.stats.bytes);
    EXPECT_TRUE(all == g.traffic.raw) << "the records' bytes are not the input's";

    // The valid frames are the frames that went out intact, each at its place in the
    // stream, but for chance: at a byte with a flipped bit, of noise, or inside a frame, a
    // reading can check by chance (1 in 65,536 for each the framer tries), and its length
    // may reach over intact frames after it. That happens about once in a few runs of
    // 100,000 frames; more is a fault.
    std::map<std::size_t, const SentFrame*> intact_at;  // by the place of its first byte
    std::size_t at = 0;
    for (const SentFrame& s : g.sent) {
        const bool frame = s.what == SentFrame::What::request || s.what == SentFrame::What::answer;
        if (frame && !s.damaged) intact_at[at] = &s;
        at += s.bytes.size();
    }
    std::map<const SentFrame*, const Record*> record_of;
    std::map<std::size_t, const Record*> by_chance;  // by the place of its last byte
    at = 0;
    for (const Record& r : records) {
        if (r.frame.cls == RecordClass::frame) {
            const auto sent = intact_at.find(at);
            if (sent != intact_at.end() && sent->second->bytes.size() == r.frame.bytes.size()) {
                record_of[sent->second] = &r;
            } else {
                by_chance[at + r.frame.bytes.size() - 1] = &r;
            }
        }
        at += r.frame.bytes.size();
    }
    std::string unexpected;
    for (const auto& [last, r] : by_chance) {
        unexpected += fmt::format("\n  #{} {:02X}", r->number, fmt::join(r->frame.bytes, " "));
    }
    constexpr std::size_t kChanceFrames = 3;
    ASSERT_LE(by_chance.size(), kChanceFrames) << "valid frames not sent:" << unexpected;
    // An intact frame not found must lie in one found by chance, whose length reached over
    // it (as far as the 256 bytes a frame can have).
    for (const auto& [first, sent] : intact_at) {
        if (record_of.contains(sent)) continue;
        const auto chance = by_chance.lower_bound(first);
        const bool inside = chance != by_chance.end() &&
                            chance->first + 1 - chance->second->frame.bytes.size() <= first;
        ASSERT_TRUE(inside) << fmt::format("not found: {:02X}", fmt::join(sent->bytes, " "))
                            << "; valid frames not sent:" << unexpected;
    }

    int failures = 0;
    auto fail = [&](const Record& r, const std::string& what) {
        if (++failures <= 10) {
            ADD_FAILURE() << fmt::format("#{} {:02X}: {}", r.number, fmt::join(r.frame.bytes, " "),
                                         what);
        }
    };
    for (const auto& [sent, r] : record_of) {
        const std::uint8_t slave = r->frame.slave();
        const Profile* profile = slave >= 1 && slave <= 4 ? bus.profile_for(slave) : nullptr;
        if (r->profile != profile) fail(*r, "decoded with the wrong profile");
        if (r->kind == Kind::unknown) fail(*r, "neither request nor answer");
    }
    ASSERT_EQ(failures, 0);

    // What each frame is and which request each answer answers, poll by poll. Order cannot
    // always tell these after a poll to the same slave and function that was left open (no
    // answer, or a frame damaged): its next request may pass for the answer. Through a run
    // of such polls answered by echoes the reading then stays one frame off. Those polls
    // are left out, as are damaged ones (docs/formats.md, "How frames are found and paired").
    const std::vector<Poll> polls = polls_of(g.sent);
    std::size_t checked = 0;
    auto found = [&](const SentFrame* frame) {
        return frame == nullptr || record_of.contains(frame);
    };
    bool previous_off = false;  // the poll before may have been read a frame off
    for (std::size_t k = 0; k < polls.size(); ++k) {
        const Poll& poll = polls[k];
        const auto key = poll.key();
        // The two polls before: a damaged frame can swallow the next request into noise.
        bool off = false;
        for (std::size_t back = 1; back <= 2 && back <= k; ++back) {
            const Poll& before = polls[k - back];
            off = off || (before.open() && before.touches(key));
        }
        off = off || (previous_off && polls[k - 1].answered_by_echo() && polls[k - 1].key() == key);
        previous_off = off;
        if (off || poll.damaged()) continue;
        if (!found(poll.request) || !found(poll.answer)) continue;  // by chance, above
        ++checked;
        const Record& request = *record_of.at(poll.request);
        const Kind request_kind = poll.broadcast() ? Kind::broadcast : Kind::request;
        if (request.kind != request_kind) {
            fail(request, fmt::format("a {}, read as a {}", to_string(request_kind),
                                      to_string(request.kind)));
        }
        if (poll.answer == nullptr) {
            // Unless the next poll, to the same slave and function, passes for its answer.
            const bool next_same = k + 1 < polls.size() && polls[k + 1].key() == key;
            if (!poll.broadcast() && !next_same && !request.notes.has(note_id::no_answer)) {
                fail(request, "unanswered, but not said to be");
            }
            continue;
        }
        const Record& answer = *record_of.at(poll.answer);
        const Kind answer_kind =
            (answer.frame.function() & 0x80U) ? Kind::exception : Kind::response;
        if (answer.kind != answer_kind) {
            fail(answer,
                 fmt::format("a {}, read as a {}", to_string(answer_kind), to_string(answer.kind)));
        }
        if (answer.request_number != request.number) {
            fail(answer, fmt::format("answers #{}, paired with #{}", request.number,
                                     answer.request_number));
        }
    }
    EXPECT_EQ(failures, 0);
    // The generator damages a frame in about 1 % of polls: nearly all are checked.
    EXPECT_GE(checked, polls.size() * 97 / 100);
}

INSTANTIATE_TEST_SUITE_P(
    , BenchTraffic,
    ::testing::Values(Case{115200, InputFormat::capture}, Case{9600, InputFormat::capture},
                      Case{115200, InputFormat::raw}, Case{9600, InputFormat::raw},
                      Case{115200, InputFormat::capture, true},
                      Case{9600, InputFormat::capture, true}),
    [](const ::testing::TestParamInfo<Case>& param) { return name_of(param.param); });

// What the benchmarks need of the traffic, as generated: the four seed devices and standard
// devices, each kind of trouble a field line has, and an adapter's batches (at most 64
// bytes, a request and its answer sometimes in one) or, per byte, a logic analyser's
// timing. Shares are checked within about half and twice what the generator aims at.
TEST(BenchTrafficMix, HoldsTheMixAndChunkingOfAFieldLine) {
    for (const bool per_byte : {false, true}) {
        SCOPED_TRACE(per_byte ? "per byte" : "batched");
        std::vector<SentFrame> sent;
        std::vector<std::size_t> chunk_ends;  // the place after each chunk's last byte
        std::vector<Nanos> byte_ends;         // per byte: when each byte ended
        std::size_t bytes = 0;
        std::size_t largest_chunk = 0;
        bench::generate_traffic(
            {.frames = 100'000, .per_byte = per_byte},
            [&](const Chunk& c) {
                bytes += c.bytes.size();
                chunk_ends.push_back(bytes);
                largest_chunk = std::max(largest_chunk, c.bytes.size());
                if (per_byte) byte_ends.push_back(c.time);
            },
            [&](const SentFrame& s) { sent.push_back(s); });
        const std::vector<Poll> polls = polls_of(sent);

        std::map<std::uint8_t, std::size_t> polls_to;  // by slave
        std::size_t broadcasts = 0, unanswered = 0, exceptions = 0, wide = 0;
        std::size_t damaged_requests = 0, damaged_answers = 0;
        for (const Poll& p : polls) {
            ++polls_to[p.key().first];
            if (p.broadcast()) ++broadcasts;
            if (p.answer == nullptr && !p.broadcast()) ++unanswered;
            if (p.request->damaged) ++damaged_requests;
            if (p.answer != nullptr && p.answer->damaged) ++damaged_answers;
            if (p.answer != nullptr && (p.answer->bytes[1] & 0x80U) != 0) ++exceptions;
            if (p.answer != nullptr && p.answer->bytes.size() > 100) ++wide;
        }
        std::size_t junk = 0, noise = 0;
        for (const SentFrame& s : sent) {
            junk += s.what == SentFrame::What::junk ? 1 : 0;
            noise += s.what == SentFrame::What::noise ? 1 : 0;
        }
        const auto n = static_cast<double>(polls.size());
        auto expect_share = [&](std::size_t count, double aim, const char* what) {
            EXPECT_GE(count, static_cast<std::size_t>(n * aim / 2)) << what << ": " << count;
            EXPECT_LE(count, static_cast<std::size_t>(n * aim * 2)) << what << ": " << count;
        };
        for (std::uint8_t seed_device = 1; seed_device <= 4; ++seed_device) {
            expect_share(polls_to[seed_device], 0.10, "polls to a seed device");
        }
        std::size_t standard = 0;
        for (std::uint8_t slave = 5; slave <= 24; ++slave) standard += polls_to[slave];
        expect_share(standard, 0.60, "polls to standard devices");
        expect_share(broadcasts, 0.002, "broadcasts");
        expect_share(unanswered, 0.01, "polls left unanswered");
        expect_share(exceptions, 0.02, "exceptions");
        expect_share(damaged_requests, 0.005, "damaged requests");
        expect_share(damaged_answers, 0.005, "damaged answers");
        expect_share(junk, 0.003, "junk bytes after answers");
        expect_share(noise, 0.002, "runs of noise");
        // 5 % of standard reads ask for 33-125 registers (up to the protocol's limit).
        expect_share(wide, 0.011, "answers of more than 100 bytes");

        // Where each frame ends and the next begins, against the chunks; per byte, when its
        // bytes ended: the relay controller answers in 150-250 ms, the others within t3.5 +
        // 4 ms.
        std::size_t at = 0;
        std::size_t shared_chunks = 0;  // a frame ending inside a chunk the next continues
        std::size_t split_frames = 0;   // a frame spread over more than one chunk
        std::size_t request_last = 0;   // the last byte of the latest request
        for (const SentFrame& s : sent) {
            const std::size_t end = at + s.bytes.size();
            const auto first = std::upper_bound(chunk_ends.begin(), chunk_ends.end(), at);
            const auto last = std::lower_bound(chunk_ends.begin(), chunk_ends.end(), end);
            if (first != last) ++split_frames;
            if (*last != end) ++shared_chunks;
            if (s.what == SentFrame::What::request) request_last = end - 1;
            if (per_byte && s.what == SentFrame::What::answer && !s.damaged) {
                const Nanos turnaround = byte_ends[at] - byte_ends[request_last];
                if (s.bytes[0] == 4) {
                    EXPECT_GE(turnaround, 150'000'000) << "relay " << at;
                } else {
                    EXPECT_LT(turnaround, 10'000'000) << "slave " << int{s.bytes[0]} << " " << at;
                }
            }
            at = end;
        }
        ASSERT_EQ(at, bytes);
        if (per_byte) {
            EXPECT_EQ(largest_chunk, 1U);
            EXPECT_EQ(chunk_ends.size(), bytes);
        } else {
            EXPECT_EQ(largest_chunk, 64U);  // full batches, never more
            EXPECT_GT(shared_chunks, sent.size() / 4);
            EXPECT_GT(split_frames, sent.size() / 100);
        }
    }
}

// The benchmarks' garbage: the same bytes for a seed, other bytes for another, and every
// byte value about as often as any other (so every function code starts searches).
TEST(BenchGarbage, SameForASeedAndUniform) {
    const auto bytes = bench::garbage(256'000, 1);
    ASSERT_EQ(bytes.size(), 256'000U);
    EXPECT_EQ(bench::garbage(256'000, 1), bytes);
    EXPECT_NE(bench::garbage(256'000, 2), bytes);
    std::array<int, 256> seen{};
    for (const auto b : bytes) ++seen[b];
    // 1,000 expected of each; ±15 % is over 4.5 standard deviations.
    for (std::size_t value = 0; value < seen.size(); ++value) {
        EXPECT_GT(seen[value], 850) << "byte " << value;
        EXPECT_LT(seen[value], 1150) << "byte " << value;
    }
}

// `bytes` one a line at 9600 baud, as a logic analyser would export a line at the wrong
// speed; with `silence_every`, a 5 ms silence before every so many bytes. Decoded into
// `sink`.
void decode_per_byte(const std::vector<std::uint8_t>& bytes, std::size_t silence_every,
                     test::CollectingSink& sink) {
    std::string capture = bench::capture_header({.baud = 9600});
    Nanos silence = 0;
    std::size_t i = 0;
    bench::garbage_per_byte(bytes, 9600, [&](Chunk c) {
        if (silence_every != 0 && i++ % silence_every == 0) silence += 5'000'000;
        c.time += silence;
        capture += capture_line(c);
    });
    auto source = source_from_memory(capture, "garbage", InputFormat::capture);
    ASSERT_TRUE(source);
    ASSERT_TRUE(run_pipeline(**source, PipelineOptions{}, sink));
}

// The benchmarks' garbage one byte a line: every byte comes out in one record, in order.
// With no silence anywhere to cut it, the noise runs long between chance frames (a few
// dozen records in all).
TEST(BenchGarbage, PerByteCaptureKeepsEveryByte) {
    const auto bytes = bench::garbage(100'000, 1);
    test::CollectingSink sink;
    ASSERT_NO_FATAL_FAILURE(decode_per_byte(bytes, 0, sink));
    std::vector<std::uint8_t> all;
    for (const Record& r : sink.records) {
        all.insert(all.end(), r.frame.bytes.begin(), r.frame.bytes.end());
    }
    EXPECT_TRUE(all == bytes) << "the records' bytes are not the input's";
    EXPECT_LT(sink.records.size(), bytes.size() / 100);
}

// The same garbage with a silence before every 100th byte, which ends whatever came before
// it: no record spans one, however long the garbage, and so however many times the framer
// has dropped what it had decided while it kept the bytes after.
TEST(BenchGarbage, PerByteCaptureWithSilencesSplitsAtEverySilence) {
    constexpr std::size_t kRun = 100;
    const auto bytes = bench::garbage(200'000, 1);
    test::CollectingSink sink;
    ASSERT_NO_FATAL_FAILURE(decode_per_byte(bytes, kRun, sink));
    std::size_t at = 0;
    int spanning = 0;
    for (const Record& r : sink.records) {
        const std::size_t end = at + r.frame.bytes.size();
        if (at / kRun != (end - 1) / kRun && ++spanning <= 5) {
            ADD_FAILURE() << fmt::format("#{}: bytes {}-{} span a silence", r.number, at, end - 1);
        }
        at = end;
    }
    EXPECT_EQ(at, bytes.size());
    EXPECT_EQ(spanning, 0);
}

}  // namespace
}  // namespace rtuscope
