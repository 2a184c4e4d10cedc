// Google Benchmark micro-benchmarks: the CRC, the capture parser, the framer.
#include <benchmark/benchmark.h>

#include <string>
#include <vector>

#include "framing/crc.hpp"
#include "framing/framer.hpp"
#include "input/sources.hpp"
#include "traffic.hpp"

namespace {

// 100,000 frames of the benchmark traffic, in both forms, generated once.
const rtuscope::bench::TrafficInMemory& data() {
    static const rtuscope::bench::TrafficInMemory d = [] {
        rtuscope::bench::TrafficOptions options;
        options.frames = 100'000;
        return rtuscope::bench::traffic_in_memory(options);
    }();
    return d;
}

void BM_Crc16Modbus256(benchmark::State& state) {
    std::vector<std::uint8_t> buf(256);
    for (std::size_t i = 0; i < buf.size(); ++i) buf[i] = static_cast<std::uint8_t>(i * 37 + 11);
    for (auto _ : state) {
        benchmark::DoNotOptimize(buf.data());
        benchmark::DoNotOptimize(rtuscope::crc16_modbus(buf));
    }
    state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations()) * 256);
}
BENCHMARK(BM_Crc16Modbus256);

// A typical frame's CRC (8 bytes: the FC03 request).
void BM_CheckCrc8(benchmark::State& state) {
    const std::vector<std::uint8_t> frame{0x01, 0x03, 0x00, 0x00, 0x00, 0x02, 0xC4, 0x0B};
    for (auto _ : state) {
        benchmark::DoNotOptimize(frame.data());
        benchmark::DoNotOptimize(rtuscope::check_crc(frame));
    }
    state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations()) * 8);
}
BENCHMARK(BM_CheckCrc8);

template <rtuscope::InputFormat Format>
void read_all(benchmark::State& state, const std::string& content) {
    for (auto _ : state) {
        state.PauseTiming();  // the copy into the source is not the parser's work
        auto source = rtuscope::source_from_memory(content, "bench", Format);
        state.ResumeTiming();
        rtuscope::Chunk chunk;
        std::size_t chunks = 0;
        while (true) {
            auto more = (*source)->next(chunk);
            if (!more.ok() || !*more) break;
            ++chunks;
        }
        benchmark::DoNotOptimize(chunks);
    }
    state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * content.size()));
}

void BM_CaptureParser(benchmark::State& state) {
    read_all<rtuscope::InputFormat::capture>(state, data().capture);
}
BENCHMARK(BM_CaptureParser)->Unit(benchmark::kMillisecond);

void BM_FramerRaw(benchmark::State& state) {
    const std::string& raw = data().raw;
    std::uint64_t frames = 0;
    for (auto _ : state) {
        rtuscope::FramerOptions options;
        rtuscope::Framer framer(options, [&](const rtuscope::Frame& f) { frames += f.is_frame(); });
        rtuscope::Chunk chunk;
        for (std::size_t at = 0; at < raw.size(); at += 4096) {
            const auto* p = reinterpret_cast<const std::uint8_t*>(raw.data()) + at;
            chunk.bytes.assign(p, p + std::min<std::size_t>(4096, raw.size() - at));
            framer.push(chunk);
        }
        framer.finish();
    }
    state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * raw.size()));
    state.counters["frames/s"] =
        benchmark::Counter(static_cast<double>(frames), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_FramerRaw)->Unit(benchmark::kMillisecond);

// The framer on the timed chunks of the capture (gaps and USB batching), parser excluded.
void BM_FramerTimedChunks(benchmark::State& state) {
    static const std::vector<rtuscope::Chunk> chunks = [] {
        std::vector<rtuscope::Chunk> out;
        rtuscope::bench::TrafficOptions options;
        options.frames = 100'000;
        rtuscope::bench::generate_traffic(options,
                                          [&](const rtuscope::Chunk& c) { out.push_back(c); });
        return out;
    }();
    std::uint64_t frames = 0;
    std::uint64_t bytes = 0;
    for (auto _ : state) {
        rtuscope::FramerOptions options;
        options.line.baud = 115200;
        rtuscope::Framer framer(options, [&](const rtuscope::Frame& f) { frames += f.is_frame(); });
        for (const auto& c : chunks) {
            framer.push(c);
            bytes += c.bytes.size();
        }
        framer.finish();
    }
    state.SetBytesProcessed(static_cast<std::int64_t>(bytes));
    state.counters["frames/s"] =
        benchmark::Counter(static_cast<double>(frames), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_FramerTimedChunks)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
