// The bus's state (`watch`): per-slave counters that are stats' own, windows, registers
// with their values, changes, min/max and history, writers, and the bounded memory.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <malloc.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>

#include "input/sources.hpp"
#include "profiles/bus.hpp"
#include "state/bus_state.hpp"
#include "watch/watch.hpp"
#include "support.hpp"

namespace rtuscope {
namespace {

using test::kMs;

// mallinfo2 measures the heap, but for AddressSanitizer's allocator, which is not malloc's.
#if defined(__SANITIZE_ADDRESS__)
constexpr bool kHeapIsMalloc = false;
#else
constexpr bool kHeapIsMalloc = true;
#endif

// Runs the pipeline over `content` into a BusState.
void feed(BusState& state, std::string content, InputFormat format, const Bus* bus = nullptr) {
    auto source = source_from_memory(std::move(content), "mem", format);
    ASSERT_TRUE(source) << source.error().to_string();
    class Sink final : public RecordSink {
      public:
        explicit Sink(BusState& s) : state_(s) {}
        void begin(const SessionInfo& session) override { state_.begin(session); }
        void record(const Record& r) override { state_.add(r); }
        void end(const Totals&, const std::vector<std::string>&) override { state_.refresh(); }

      private:
        BusState& state_;
    } sink(state);
    PipelineOptions options;
    options.bus = bus;
    ASSERT_TRUE(run_pipeline(**source, options, sink));
}

std::string capture(const std::vector<std::string>& lines) {
    std::string out = "# rtuscope capture v1\n# serial 9600 8N1\n";
    for (const auto& l : lines) out += l + "\n";
    return out;
}

// The PDU485's voltage read three times: 230.1, 230.1, 231.0 V.
const std::vector<std::string> kThreeReads = {
    "0.000 01 03 00 00 00 01 84 0A", "0.030 01 03 02 08 FD 7E 05",
    "1.000 01 03 00 00 00 01 84 0A", "1.030 01 03 02 08 FD 7E 05",
    "2.000 01 03 00 00 00 01 84 0A", "2.030 01 03 02 09 06 3E 16",
};

TEST(BusState, ARegisterKeepsItsNameUnitValueChangesAndRange) {
    Bus bus;
    ASSERT_TRUE(bus.assign(1, "pdu485"));
    BusState state;
    feed(state, capture(kThreeReads), InputFormat::capture, &bus);
    const RegisterState* r = state.find({1, static_cast<std::uint8_t>(DataTable::holding_registers), 0});
    ASSERT_NE(r, nullptr);
    EXPECT_EQ(r->value, "231.0");
    EXPECT_NE(state.text(r->name), "");
    EXPECT_EQ(state.text(r->unit), "V");
    EXPECT_EQ(r->raw[0], 0x0906);
    EXPECT_EQ(r->changes, 1U);
    EXPECT_FLOAT_EQ(r->min, 230.1F);
    EXPECT_FLOAT_EQ(r->max, 231.0F);
    ASSERT_EQ(r->history.size(), 3U);
    EXPECT_FLOAT_EQ(r->history.at(0), 230.1F);
    EXPECT_FLOAT_EQ(r->history.at(2), 231.0F);
    // The answer's start: the request's end (8 characters) plus the turnaround.
    EXPECT_GT(r->last_change, 2 * kNanosPerSecond);
    EXPECT_LT(r->last_update, 2 * kNanosPerSecond + 40 * kMs);
    EXPECT_EQ(r->last_update, r->last_change);
    EXPECT_EQ(state.write(*r), nullptr);
}

TEST(BusState, WithoutAProfileRegistersAreRawWordsByAddress) {
    BusState state;
    feed(state, capture(kThreeReads), InputFormat::capture);
    const RegisterState* r = state.find({1, static_cast<std::uint8_t>(DataTable::holding_registers), 0});
    ASSERT_NE(r, nullptr);
    EXPECT_EQ(r->value, "2310");  // 0x0906
    EXPECT_EQ(state.text(r->name), "");
    EXPECT_EQ(state.registers(1).size(), 1U);
}

// A slave's counters are the stats rows of that slave, summed: the same figures.
TEST(BusState, SlaveFiguresAreTheStatsRowsSummed) {
    BusState state;
    feed(state,
         capture({"1.000 01 03 00 00 00 01 84 0A", "1.030 01 03 02 08 FD 7E 05",
                  "2.000 01 03 00 00 00 01 84 0A",                         // no answer
                  "3.000 01 06 00 01 00 03 98 0B", "3.030 01 86 02 C3 A1",  // exception
                  "4.000 02 03 00 00 00 01 84 39"}),
         InputFormat::capture);
    const FunctionStats one = state.figures(1);
    EXPECT_EQ(one.requests, 3U);
    EXPECT_EQ(one.answers, 1U);
    EXPECT_EQ(one.no_answer, 1U);
    EXPECT_EQ(one.exceptions, 1U);
    EXPECT_EQ(one.exception_codes.at(2), 1U);
    EXPECT_EQ(state.figures(2).no_answer, 1U);
    ASSERT_EQ(state.slaves().size(), 2U);
    EXPECT_EQ(state.slave(1)->writes, 1U);
    EXPECT_EQ(state.slave(1)->turnarounds.size(), 2U);
    // A frame's start: its end, as the capture stamps it, less 8 characters.
    EXPECT_EQ(state.slave(1)->first_seen, kNanosPerSecond - 8 * LineSettings{}.char_time());
    EXPECT_GE(state.slave(1)->last_seen, 3 * kNanosPerSecond);
    // Errors in the last minute: the unanswered requests and the exception.
    EXPECT_EQ(state.errors().within(state.last_time(), 60), 3U);
    ASSERT_EQ(state.anomalies().size(), 3U);
    EXPECT_EQ(state.anomalies()[1], "#5 slave 1 exception 02 Illegal Data Address");
}

// A write shows at once as written by its request, confirmed when the echo comes; an
// exception leaves it unconfirmed.
TEST(BusState, AWriteIsTrackedFromItsRequestToItsEcho) {
    BusState state;
    feed(state,
         capture({"1.000 01 06 00 01 00 03 98 0B", "1.030 01 06 00 01 00 03 98 0B",
                  "2.000 01 06 00 02 00 07 69 C8", "2.030 01 86 02 C3 A1"}),
         InputFormat::capture);
    const auto holding = static_cast<std::uint8_t>(DataTable::holding_registers);
    const RegisterState* confirmed = state.find({1, holding, 1});
    ASSERT_NE(confirmed, nullptr);
    EXPECT_EQ(confirmed->value, "3");
    const RegisterWrite* w = state.write(*confirmed);
    ASSERT_NE(w, nullptr);
    EXPECT_EQ(w->by, 1U);
    EXPECT_EQ(w->at, kNanosPerSecond - 8 * LineSettings{}.char_time());
    EXPECT_TRUE(w->confirmed);
    const RegisterState* refused = state.find({1, holding, 2});
    ASSERT_NE(refused, nullptr);
    ASSERT_NE(state.write(*refused), nullptr);
    EXPECT_EQ(state.write(*refused)->by, 3U);
    EXPECT_FALSE(state.write(*refused)->confirmed);
}

TEST(BusState, RatesCountTheLastSecondsOnTheRecordsClock) {
    PerSecond p;
    p.add(10 * kNanosPerSecond);
    p.add(10 * kNanosPerSecond + 500 * kMs);
    p.add(11 * kNanosPerSecond);
    EXPECT_EQ(p.within(11 * kNanosPerSecond, 1), 1U);
    EXPECT_EQ(p.within(11 * kNanosPerSecond, 2), 3U);
    // A minute later the window has moved past them all.
    EXPECT_EQ(p.within(71 * kNanosPerSecond, 60), 0U);
    p.add(200 * kNanosPerSecond);
    EXPECT_EQ(p.within(200 * kNanosPerSecond, 60), 1U);
}

TEST(BusState, TurnaroundPercentilesCoverTheLastWindowOnly) {
    RecentDurations d;
    for (int i = 0; i < 1000; ++i) d.add(1000);  // old, fast
    for (std::size_t i = 0; i < RecentDurations::kSize; ++i) d.add(static_cast<Nanos>(i + 1));
    EXPECT_EQ(d.size(), RecentDurations::kSize);
    EXPECT_EQ(*d.percentile(50), 128);
    EXPECT_EQ(*d.percentile(100), 256);
}

// More registers than the cap: the least recently updated go, counted, and the state
// stays under 16 MiB.
TEST(BusState, RegistersAreCappedAndTheStateStaysUnder16MiB) {
    // Heap in use, small blocks and those mmap'ed alike.
    auto heap = [] {
        const struct mallinfo2 m = mallinfo2();
        return m.uordblks + m.hblkhd;
    };
    const std::size_t before = heap();
    auto state = std::make_unique<BusState>();
    // Reads of 100 registers from every address of slaves 1-20: 20 x 65536 registers.
    std::string content = "# rtuscope capture v1\n# serial 115200 8N1\n";
    Nanos t = 0;
    auto line = [&](const test::Bytes& frame) {
        content += fmt::format("{:.6f}", static_cast<double>(t) / 1e9);
        for (std::uint8_t b : frame) content += fmt::format(" {:02X}", b);
        content += '\n';
        t += 20 * kMs;
    };
    std::size_t registers = 0;
    for (std::uint8_t slave = 1; slave <= 2; ++slave) {
        for (std::uint32_t start = 0; start + 100 <= 65536 && registers < 80000; start += 100) {
            const auto hi = static_cast<std::uint8_t>(start >> 8);
            const auto lo = static_cast<std::uint8_t>(start & 0xFF);
            line(test::with_crc({slave, 0x03, hi, lo, 0x00, 100}));
            test::Bytes answer{slave, 0x03, 200};
            for (int i = 0; i < 100; ++i) {
                answer.push_back(static_cast<std::uint8_t>(i));
                answer.push_back(static_cast<std::uint8_t>(start));
            }
            line(test::with_crc(answer));
            registers += 100;
        }
    }
    feed(*state, std::move(content), InputFormat::capture);
    EXPECT_EQ(state->register_count(), BusState::kMaxRegisters);
    EXPECT_EQ(state->forgotten_registers(), registers - BusState::kMaxRegisters);
    // The first registers read are the ones forgotten; every one of the last is there
    // (the index finds each after thousands of removals).
    const auto holding = static_cast<std::uint8_t>(DataTable::holding_registers);
    EXPECT_EQ(state->find({1, holding, 0}), nullptr);
    std::size_t found = 0;
    for (std::uint8_t slave = 1; slave <= 2; ++slave) {
        for (std::uint32_t a = 0; a < 65500; ++a) {
            const RegisterState* r = state->find({slave, holding, static_cast<std::uint16_t>(a)});
            if (r == nullptr) continue;
            EXPECT_EQ(r->key, (RegisterKey{slave, holding, static_cast<std::uint16_t>(a)}));
            ++found;
        }
    }
    EXPECT_EQ(found, BusState::kMaxRegisters);
    const auto first_kept = static_cast<std::uint16_t>(registers - BusState::kMaxRegisters);
    EXPECT_EQ(state->find({1, holding, static_cast<std::uint16_t>(first_kept - 1)}), nullptr);
    EXPECT_NE(state->find({1, holding, first_kept}), nullptr);
    const std::size_t used = heap() - before;
    if (kHeapIsMalloc) {
        EXPECT_LT(used, std::size_t{16} << 20) << used;
        EXPECT_GT(used, std::size_t{8} << 20) << used;  // the measure sees the state
    }
}

// stats and the state count the same records alike, on every bundled capture.
TEST(BusState, FiguresAgreeWithStatsOnEveryCapture) {
    std::size_t captures = 0;
    for (const auto& entry : std::filesystem::recursive_directory_iterator(
             std::filesystem::path(RTUSCOPE_SOURCE_DIR) / "captures")) {
        const std::string ext = entry.path().extension().string();
        if (!entry.is_regular_file() || ext == ".md" || ext == ".toml") continue;
        SCOPED_TRACE(entry.path().string());
        std::ifstream in(entry.path(), std::ios::binary);
        std::string content((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
        BusState state;
        feed(state, content, InputFormat::automatic);
        FunctionStats sum;
        for (const SlaveState* s : state.slaves()) {
            add_function_counts(sum, state.figures(s->address));
        }
        const FunctionStats& all = state.stats().all();
        // Rows of frames no slave state was made for (broken frames of nobody's) aside,
        // every request and outcome of stats is a slave's.
        EXPECT_EQ(sum.requests, all.requests);
        EXPECT_EQ(sum.answers, all.answers);
        EXPECT_EQ(sum.exceptions, all.exceptions);
        EXPECT_EQ(sum.broken, all.broken);
        EXPECT_EQ(sum.no_answer, all.no_answer);
        ++captures;
    }
    EXPECT_GT(captures, 20U);
}

// watch --plain: each table's heading says the local time, with the date on the first
// one and whenever the date changes; and what the recording did, when there is one.
TEST(PlainDisplay, HeadingsShowTheDateWhenItChangesAndTheRecording) {
    const test::ScopedZone tz("UTC0");
    char* text = nullptr;
    std::size_t size = 0;
    std::FILE* out = open_memstream(&text, &size);
    ASSERT_NE(out, nullptr);
    {
        auto display = make_plain_display(out, 3600 * kNanosPerSecond);
        int files = 1;
        display->set_recording([&] { return fmt::format("recording bus.rtucap ({} files)", files); });
        BusState state;
        constexpr Nanos kEvening = 1'795'823'990 * kNanosPerSecond;  // 2026-11-27 23:59:50 UTC
        display->show(state, kEvening);  // the first interval starts
        display->show(state, kEvening + 3600 * kNanosPerSecond);
        files = 2;
        display->show(state, kEvening + 7200 * kNanosPerSecond);
        display->show(state, kEvening + 2 * 86'400 * kNanosPerSecond);
    }
    std::fclose(out);
    const std::string shown(text, size);
    std::free(text);
    std::vector<std::string> headings;
    std::istringstream in(shown);
    for (std::string line; std::getline(in, line);) {
        if (line.starts_with("-- at ") || line.starts_with("recording ")) headings.push_back(line);
    }
    EXPECT_EQ(headings, (std::vector<std::string>{
                            "-- at 2026-11-28 00:59:50", "recording bus.rtucap (1 files)",
                            "-- at 01:59:50", "recording bus.rtucap (2 files)",
                            "-- at 2026-11-29 23:59:50", "recording bus.rtucap (2 files)"}));
}

}  // namespace
}  // namespace rtuscope
