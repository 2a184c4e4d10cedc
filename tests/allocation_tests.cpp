// Allocations on the decoding path: once its buffers have grown to fit the traffic, a
// decode allocates nothing per frame or per register value, whichever output it writes;
// and the heap it keeps stays bounded on traffic crafted to grow it. This binary replaces
// the global operator new to count calls and the bytes in use; it is kept apart from
// rtuscope_tests, whose sanitizer build keeps the sanitizers' own operator new.
#include <gtest/gtest.h>
#include <malloc.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <memory>
#include <new>
#include <stdexcept>
#include <string>
#include <vector>

#include "input/capture_writer.hpp"
#include "input/pcap.hpp"
#include "input/sources.hpp"
#include "output/pcap_writer.hpp"
#include "output/sinks.hpp"
#include "output/trigger.hpp"
#include "pipeline.hpp"
#include "state/bus_state.hpp"
#include "stats/report.hpp"
#include "support.hpp"
#include "util/text.hpp"

namespace {
// The tests run on one thread.
std::uint64_t g_allocations = 0;
std::size_t g_heap_bytes = 0;  // in use now (as malloc counts them)
std::size_t g_heap_peak = 0;   // the most in use since it was last set

void* counted(void* p) {
    if (p != nullptr) {
        ++g_allocations;
        g_heap_bytes += malloc_usable_size(p);
        g_heap_peak = std::max(g_heap_peak, g_heap_bytes);
    }
    return p;
}

void release(void* p) {
    if (p != nullptr) g_heap_bytes -= malloc_usable_size(p);
    std::free(p);
}
}  // namespace

// None inlined: GCC would then see free() meet a pointer from `new`, or a `delete` one from
// malloc(), and call it a mismatch.
[[gnu::noinline]] void* operator new(std::size_t size) {
    if (void* p = counted(std::malloc(size == 0 ? 1 : size))) return p;
    throw std::bad_alloc();
}
void* operator new[](std::size_t size) {
    return operator new(size);
}
// The nothrow forms too (std::stable_sort's buffer): each form must meet its own delete.
[[gnu::noinline]] void* operator new(std::size_t size, const std::nothrow_t& /*tag*/) noexcept {
    return counted(std::malloc(size == 0 ? 1 : size));
}
void* operator new[](std::size_t size, const std::nothrow_t& tag) noexcept {
    return operator new(size, tag);
}
[[gnu::noinline]] void operator delete(void* p) noexcept {
    release(p);
}
[[gnu::noinline]] void operator delete[](void* p) noexcept {
    release(p);
}
[[gnu::noinline]] void operator delete(void* p, std::size_t /*size*/) noexcept {
    release(p);
}
[[gnu::noinline]] void operator delete[](void* p, std::size_t /*size*/) noexcept {
    release(p);
}
[[gnu::noinline]] void operator delete(void* p, const std::nothrow_t& /*tag*/) noexcept {
    release(p);
}
[[gnu::noinline]] void operator delete[](void* p, const std::nothrow_t& /*tag*/) noexcept {
    release(p);
}

namespace rtuscope {
namespace {

using test::Bytes;

// The frames of `cycles` polls of the four seed devices: whole tables with named, scaled,
// enumerated, 32-bit and unlisted registers, and a write to a read-only one.
std::vector<Bytes> seed_device_polls(int cycles) {
    std::vector<Bytes> frames;
    // A read of `count` registers from 0x0000 and its answer, with words that differ from
    // register to register (out of range, unlabelled: every kind of value note).
    auto read = [&](std::uint8_t slave, std::uint8_t count) {
        frames.push_back(test::with_crc({slave, 0x03, 0x00, 0x00, 0x00, count}));
        Bytes answer = {slave, 0x03, static_cast<std::uint8_t>(2 * count)};
        for (unsigned i = 0; i < count; ++i) {
            answer.push_back(static_cast<std::uint8_t>(0x40 + 7 * i));
            answer.push_back(static_cast<std::uint8_t>(0x13 * i));
        }
        frames.push_back(test::with_crc(answer));
    };
    for (int c = 0; c < cycles; ++c) {
        read(1, 1);   // zb-uvi485
        read(2, 20);  // sensor-analyser: named and unlisted registers
        read(3, 29);  // pdu485: the whole table
        const Bytes write = test::with_crc({3, 0x06, 0x00, 0x00, 0x12, 0x34});  // read-only
        frames.push_back(write);
        frames.push_back(write);
        read(4, 16);  // zyi-relay: labelled channels
    }
    return frames;
}

using test::raw_dump;

// The frames as a native capture at 115200 baud, 5 ms of silence after each: a frame a
// line as an adapter hands them over, or a byte a line as a logic analyser exports them.
std::string timed_capture(const std::vector<Bytes>& frames, bool per_byte) {
    LineSettings line;
    line.baud = 115200;
    SourceInfo header;
    header.line = line;
    std::string capture = capture_header(header);
    Chunk chunk;
    chunk.time = 1'000'000'000;
    for (const Bytes& frame : frames) {
        chunk.time += 5'000'000;
        if (per_byte) {
            for (const std::uint8_t byte : frame) {
                chunk.time += line.char_time();
                chunk.bytes.assign(1, byte);
                capture += capture_line(chunk);
            }
        } else {
            chunk.time += static_cast<Nanos>(frame.size()) * line.char_time();
            chunk.bytes = frame;
            capture += capture_line(chunk);
        }
    }
    return capture;
}

using test::MakeSink;

// What decoding the input of the seed devices' bus (1-4) into `make_sink`'s output counts.
struct Decoded {
    Totals totals;
    std::uint64_t allocations = 0;
    std::size_t heap_peak = 0;  // above the heap in use before
};

Decoded decode_seed_bus(ChunkSource& source, const MakeSink& make_sink) {
    Bus bus;
    EXPECT_TRUE(test::assign_seed_devices(bus));
    PipelineOptions options;
    options.bus = &bus;
    std::unique_ptr<FILE, int (*)(FILE*)> null(std::fopen("/dev/null", "w"), &std::fclose);
    EXPECT_NE(null, nullptr);
    std::unique_ptr<RecordSink> sink = make_sink(null.get());
    Decoded decoded;
    const std::uint64_t allocations_before = g_allocations;
    const std::size_t heap_before = g_heap_bytes;
    g_heap_peak = g_heap_bytes;
    EXPECT_TRUE(run_pipeline(source, options, *sink, &decoded.totals));
    decoded.allocations = g_allocations - allocations_before;
    decoded.heap_peak = g_heap_peak - heap_before;
    return decoded;
}

Decoded decode_seed_bus(std::string input, const MakeSink& make_sink,
                        InputFormat format = InputFormat::raw) {
    auto source = source_from_memory(std::move(input), "input", format);
    if (!source) {
        ADD_FAILURE() << source.error().to_string();
        return {};
    }
    return decode_seed_bus(**source, make_sink);
}

std::unique_ptr<RecordSink> csv_sink(FILE* f) {
    return make_csv_sink(f);
}

// A sink writing the pcap of `--pcap` to `path`, in place of the output it is given.
MakeSink pcap_sink_into(const std::string& path) {
    return [path](FILE* /*output*/) -> std::unique_ptr<RecordSink> {
        auto sink = make_pcap_sink(path);
        if (!sink) throw std::runtime_error(sink.error().to_string());
        return std::move(*sink);
    };
}

// Every record of `cycles` seed polls came out: 10 a cycle, 5 of them answers.
void expect_all_polls_decoded(const Decoded& decoded, int cycles) {
    EXPECT_EQ(decoded.totals.records, 10U * static_cast<std::uint64_t>(cycles));
    EXPECT_EQ(decoded.totals.responses, 5U * static_cast<std::uint64_t>(cycles));
}

// Decodes `cycles` polls of the seed devices, from an input the test makes.
using DecodePolls = std::function<Decoded(int cycles)>;

// Twice the polls, the same allocations: none per frame, per value or per line. (Each run
// is over 64 KiB, the framer's window, so that its buffers reach their working size in
// both: 400 polls are 80 KB.) `input` names the input in a failure.
void expect_no_allocation_per_frame(const DecodePolls& decode, const std::string& input) {
    std::uint64_t allocations[2] = {0, 0};
    for (const int cycles : {400, 800}) {
        const Decoded decoded = decode(cycles);
        expect_all_polls_decoded(decoded, cycles);
        allocations[cycles == 800] = decoded.allocations;
    }
    EXPECT_EQ(allocations[1], allocations[0])
        << input << ": 400 cycles " << allocations[0] << ", 800 cycles " << allocations[1];
}

// The polls as a raw dump, decoded into the output `make_sink` gives.
void expect_no_allocation_per_frame_into(const MakeSink& make_sink) {
    expect_no_allocation_per_frame(
        [&](int cycles) { return decode_seed_bus(raw_dump(seed_device_polls(cycles)), make_sink); },
        "raw dump");
}

TEST(Allocations, NonePerFrameDecodingToText) {
    expect_no_allocation_per_frame_into([](FILE* f) { return make_text_sink(f, TextOptions{}); });
}

TEST(Allocations, NonePerFrameDecodingToCsv) {
    expect_no_allocation_per_frame_into(csv_sink);
}

TEST(Allocations, NonePerFrameDecodingToJsonLines) {
    expect_no_allocation_per_frame_into([](FILE* f) { return make_jsonl_sink(f); });
}

TEST(Allocations, NonePerFrameDecodingToTheValuesCsv) {
    expect_no_allocation_per_frame_into([](FILE* f) { return make_values_csv_sink(f); });
}

// The bus state of `watch`: every value kept in its register's room, no node per frame.
TEST(Allocations, NonePerFrameKeepingTheBusState) {
    expect_no_allocation_per_frame_into([](FILE* /*f*/) -> std::unique_ptr<RecordSink> {
        class StateSink final : public RecordSink {
          public:
            void begin(const SessionInfo& session) override { state_.begin(session); }
            void record(const Record& r) override { state_.add(r); }
            void end(const Totals&, const std::vector<std::string>&) override {}

          private:
            BusState state_;
        };
        return std::make_unique<StateSink>();
    });
}

// Triggers run on every record of a live line: matching one parses and allocates
// nothing, whichever terms it has and whether it fires or not.
TEST(Allocations, NonePerFrameMatchingTriggers) {
    std::uint64_t events = 0;
    expect_no_allocation_per_frame_into([&](FILE* f) {
        Bus bus;
        EXPECT_TRUE(test::assign_seed_devices(bus));
        std::vector<Trigger> triggers;
        for (const char* expr :
             {"slave=9,kind=exception", "function=16,crc=bad,swapped", "uv_intensity=1,2,3",
              "voltage>1000", "flag=txn.no_answer,value.out_of_range", "relay1=on"}) {
            auto trigger = parse_trigger(expr, trigger_context(&bus));
            EXPECT_TRUE(trigger) << expr;
            if (trigger) triggers.push_back(*trigger);
        }
        return make_trigger_sink(
            std::move(triggers), [&](const Record& /*r*/, std::size_t /*i*/) { ++events; },
            make_csv_sink(f));
    });
    EXPECT_GT(events, 0U);
}

// Each packet record is built in the same room.
TEST(Allocations, NonePerFrameWritingAPcap) {
    const test::TempDir dir;
    expect_no_allocation_per_frame_into(pcap_sink_into(dir.file("out.pcap")));
}

// The same polls as timed captures, a frame a line and a byte a line: nothing per line or
// per silence either (the framer lists the silences that end frames, and must drop them
// with the bytes it has decided).
TEST(Allocations, NonePerFrameDecodingTimedCaptures) {
    for (const bool per_byte : {false, true}) {
        expect_no_allocation_per_frame(
            [&](int cycles) {
                return decode_seed_bus(timed_capture(seed_device_polls(cycles), per_byte), csv_sink,
                                       InputFormat::capture);
            },
            per_byte ? "a byte a line" : "a frame a line");
    }
}

// Read from a file, not memory: the input buffer keeps its working size (64 KiB, or the
// longest line) however long the file. Before reading on it moves what it has not handed
// out to its front; were it to grow instead, it would end as large as the file. A pcap is
// libpcap's to read, each packet into the same chunk.
TEST(Allocations, NonePerFrameReadingFiles) {
    const test::TempDir dir;
    const std::string path = dir.file("input");
    for (const std::string format : {"raw", "capture", "pcap"}) {
        expect_no_allocation_per_frame(
            [&](int cycles) {
                const std::vector<Bytes> frames = seed_device_polls(cycles);
                if (format == "raw") dir.write("input", raw_dump(frames));
                if (format == "capture") dir.write("input", timed_capture(frames, false));
                if (format == "pcap") decode_seed_bus(raw_dump(frames), pcap_sink_into(path));
                auto source = open_source(path, InputFormat::automatic);
                if (!source) {
                    ADD_FAILURE() << source.error().to_string();
                    return Decoded{};
                }
                EXPECT_EQ((*source)->info().format, format);
                return decode_seed_bus(**source, csv_sink);
            },
            format);
    }
}

// A hex log keeps the lines that held no frame as ranges for its closing remark, and
// only the first 1,000 ranges: a log with a comment after every frame (skipped lines in
// ranges of one) costs no more memory for 8,000 of them than for 4,000.
TEST(Allocations, NonePerSkippedLineOfAHexLog) {
    expect_no_allocation_per_frame(
        [](int cycles) {
            std::string log;
            for (const Bytes& frame : seed_device_polls(cycles)) {
                append_hex(log, frame, true);
                log += "\nno frame on this line\n";
            }
            return decode_seed_bus(log, csv_sink, InputFormat::hex);
        },
        "hex log");
}

// Peak RSS below 32 MiB whatever the capture: the pairing stage keeps a few records'
// buffers, not one per slot a wait once grew. A read nobody answers, 200 frames held
// behind it, then 400 writes of 1,968 coils to the relay controller that go unanswered
// too (a master retrying a dead slave): each write's values are ~500 KB, and their records
// go round all 256 slots the wait has grown. Guards against every slot keeping its values:
// the heap stays within a few records' worth.
TEST(Memory, UnansweredLargeWritesAfterAWaitKeepAFewRecords) {
    std::vector<Bytes> frames;
    frames.push_back(test::with_crc({9, 0x03, 0x00, 0x00, 0x00, 0x01}));
    for (int i = 0; i < 200; ++i) frames.push_back(test::with_crc({2, 0x83, 0x02}));
    const Bytes header = {4, 0x0F, 0x00, 0x00, 0x07, 0xB0, 246};  // 1,968 coils from 0
    Bytes write(header.size() + 246, 0x55);
    std::copy(header.begin(), header.end(), write.begin());
    for (int i = 0; i < 400; ++i) frames.push_back(test::with_crc(write));
    const Decoded decoded = decode_seed_bus(raw_dump(frames), csv_sink);
    EXPECT_EQ(decoded.totals.records, 601U);
    EXPECT_LT(decoded.heap_peak, std::size_t{8} << 20U) << decoded.heap_peak << " bytes";
}

// A table of durations (a row's turnarounds, a poll's cycles) keeps to ~22 KiB however
// many values come (durations.hpp): bins, and a batch of values waiting to be counted.
// While a batch is counted, the old and the merged bins live at once: twice that, briefly.
TEST(Memory, ADurationTableKeepsToItsBoundHoweverManyValues) {
    for (const int values : {1'000, 300'000}) {
        const std::size_t heap_before = g_heap_bytes;
        g_heap_peak = g_heap_bytes;
        auto counts = std::make_unique<DurationCounts>();
        for (int i = 0; i < values; ++i) counts->add(Nanos{i} * 1000 + i % 7);
        counts->finish();
        EXPECT_EQ(counts->size(), static_cast<std::uint64_t>(values));
        const std::size_t kept = g_heap_bytes - heap_before;
        EXPECT_LE(kept, std::size_t{22} << 10U) << values << " values";
        EXPECT_LE(g_heap_peak - heap_before, std::size_t{64} << 10U) << values << " values";
    }
}

// Sets of durations given to a BusStats: `large` sets of 1,100 distinct values and `small`
// sets of 20 (rows' turnarounds, from answers; or polls' cycles, from requests).
class DurationSets {
  public:
    explicit DurationSets(bool polls) : polls_(polls) {}
    void add_large(BusStats& stats) const {
        for (unsigned set = 0; set < kLarge; ++set) add(stats, set, 1'100);
    }
    void add_small(BusStats& stats) const {
        for (unsigned set = kLarge; set < kLarge + small(); ++set) add(stats, set, 20);
    }
    // Rows: 247 slaves x functions 9-40 besides the large ones; polls: the whole table.
    [[nodiscard]] unsigned small() const { return polls_ ? BusStats::kMaxPolls - kLarge : 7'904; }
    static constexpr unsigned kLarge = 512;

  private:
    void add(BusStats& stats, unsigned set, int values) const {
        Record r;
        if (polls_) {  // reads of register `set` from slave 1; cycles 2 ms, 2.007 ms ...
            r.kind = Kind::request;
            r.awaits_answer = true;
            r.frame.bytes = test::with_crc({1, 0x03, static_cast<std::uint8_t>(set >> 8U),
                                            static_cast<std::uint8_t>(set), 0x00, 0x01});
        } else {  // answers from their own slave and function; 2 ms, 2.007 ms ...
            const unsigned slave = set < kLarge ? 1 + set / 8 : 1 + (set - kLarge) / 32;
            const unsigned function = set < kLarge ? 1 + set % 8 : 9 + (set - kLarge) % 32;
            r.kind = Kind::response;
            r.frame.bytes = test::with_crc(
                {static_cast<std::uint8_t>(slave), static_cast<std::uint8_t>(function), 0x00});
        }
        r.frame.crc = check_crc(r.frame.bytes);
        Nanos time = 0;
        for (int i = 0; i <= values; ++i) {
            const Nanos duration = Nanos{2'000 + 7 * i} * 1000;
            time += duration;
            r.frame.start = time;
            r.frame.end = time + 1000;
            r.latency = duration;
            if (polls_ || i < values) stats.add(r);  // n + 1 requests make n cycles
        }
    }
    bool polls_;
};

// Sets that held 1,024 bins each while they were few give the room back when more sets
// come and the share drops (bus_stats.hpp: BusStats::kBinBudget). 512 sets of 1,100
// values (1,024 bins each: 9.6 MB alone) and many of 20, which bring the share down: the
// heap kept at the end is no larger than if the large sets had come last, when the share
// was already down. For rows' turnarounds and for polls' cycles.
TEST(Memory, StatsGiveBackTheRoomOfALargerShare) {
    for (const bool polls : {false, true}) {
        const DurationSets sets(polls);
        std::size_t kept[2] = {0, 0};
        for (const bool large_first : {true, false}) {
            const std::size_t heap_before = g_heap_bytes;
            auto stats = std::make_unique<BusStats>();
            if (large_first) {
                sets.add_large(*stats);
                sets.add_small(*stats);
            } else {
                sets.add_small(*stats);
                sets.add_large(*stats);
            }
            stats->finish();
            // 2^19 bins among the sets, in a power of 2: 32 each for 8,416 rows, 128 each
            // for 4,096 polls.
            EXPECT_EQ(stats->bins_each(), polls ? 128U : 32U);
            EXPECT_EQ(polls ? stats->polls().size() : stats->functions().size(),
                      DurationSets::kLarge + sets.small());
            EXPECT_EQ(stats->forgotten_polls(), 0U);
            kept[large_first ? 0 : 1] = g_heap_bytes - heap_before;
        }
        // Coming last, the large sets keep some room to spare (a batch's worth of bins
        // each, ~6% more for the polls here); first, they must keep no more than that.
        EXPECT_LE(kept[0], kept[1] + kept[1] / 20)
            << (polls ? "polls" : "rows") << ": large sets first " << kept[0] << " bytes, last "
            << kept[1] << " bytes";
    }
}

}  // namespace
}  // namespace rtuscope
