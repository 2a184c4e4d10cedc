// The fuzz targets' bodies, shared by the libFuzzer entry points (fuzz/*.cpp) and the unit
// test that replays the seed corpora and every input a fuzzer ever crashed on
// (tests/test_fuzz_regressions.cpp). Kept in a header so that the test runs exactly what
// the fuzzer ran, under the normal build. Each returns normally for every input: errors
// are results, never exceptions or crashes.
#pragma once

#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "input/pcap.hpp"
#include "input/sources.hpp"
#include "output/filter.hpp"
#include "output/sinks.hpp"
#include "pipeline.hpp"
#include "profiles/bus.hpp"
#include "profiles/profile.hpp"
#include "stats/report.hpp"

namespace rtuscope::fuzz {

inline std::string as_string(const std::uint8_t* data, std::size_t size) {
    return size == 0 ? std::string() : std::string(reinterpret_cast<const char*>(data), size);
}

// The four bundled profiles on addresses 1-4, so that register decoding and the profile
// checks (value ranges, enums, bits, device limits) run on whatever the fuzzer makes up.
inline const Bus& seed_bus() {
    static const Bus bus = [] {
        Bus b;
        (void)b.assign(1, "zb-uvi485");
        (void)b.assign(2, "sensor-analyser");
        (void)b.assign(3, "pdu485");
        (void)b.assign(4, "zyi-relay");
        return b;
    }();
    return bus;
}

// Output goes nowhere, but through the real formatting code. Opened once: a fuzzer runs
// millions of inputs and must not leak a descriptor per input.
inline std::FILE* null_output() {
    static std::FILE* out = std::fopen("/dev/null", "w");
    return out;
}

// Reads every chunk; the limit only guards against a reader that never ends, which the
// fuzzer would report as a timeout anyway.
inline void drain(ChunkSource& source) {
    Chunk chunk;
    for (int i = 0; i < 10'000'000; ++i) {
        auto more = source.next(chunk);
        if (!more.ok() || !*more) break;
    }
}

// Bytes from the line through the whole chain (framer, pairing, decoder with the four
// profiles) into every sink at once, the statistics in each format too. The same bytes
// are read as a raw dump, as a capture v1 text and as a hex log, so one input reaches the
// framer's length and CRC search as well as the timing rules fed by the text readers'
// timestamps.
inline void pipeline(const std::uint8_t* data, std::size_t size) {
    for (const InputFormat format : {InputFormat::raw, InputFormat::capture, InputFormat::hex}) {
        auto source = source_from_memory(as_string(data, size), "fuzz", format);
        if (!source) continue;
        std::vector<std::unique_ptr<RecordSink>> sinks;
        TextOptions text;
        text.hex = true;
        text.time_format = TimeFormat::delta;
        sinks.push_back(make_text_sink(null_output(), text));
        sinks.push_back(make_csv_sink(null_output()));
        sinks.push_back(make_jsonl_sink(null_output()));
        sinks.push_back(make_values_csv_sink(null_output()));
        for (const StatsFormat stats : {StatsFormat::text, StatsFormat::csv, StatsFormat::jsonl}) {
            sinks.push_back(make_stats_sink(null_output(), stats));
        }
        auto sink = make_tee_sink(std::move(sinks));
        PipelineOptions options;
        options.bus = &seed_bus();
        options.timeout = 50'000'000;  // short, so that unanswered requests are reported too
        (void)run_pipeline(**source, options, *sink);
    }
}

// Profile files as users write them: TOML parser, the checks, formula expansion.
inline void profile_loader(const std::uint8_t* data, std::size_t size) {
    (void)load_profile_text(as_string(data, size), "fuzz.toml");
}

// pcap and pcapng files: libpcap (and rtuscope's own pcapng reader where libpcap refuses
// a file), then the link-type parsers, TCP reassembly and the flows; and the same bytes
// through rtuscope's pcapng reader alone.
inline void pcap_reader(const std::uint8_t* data, std::size_t size) {
    auto source = source_from_memory(as_string(data, size), "fuzz.pcap", InputFormat::pcap);
    if (source) drain(**source);
    auto own = pcapng_source_from_memory(as_string(data, size), "fuzz.pcapng");
    if (own) drain(**own);
}

// The readers alone, without the chain behind them; the first byte picks the format
// (capture v1, raw, hex log, or detected from the content, which may also pick pcap).
inline void capture_reader(const std::uint8_t* data, std::size_t size) {
    if (size == 0) return;
    static constexpr InputFormat kFormats[] = {InputFormat::raw, InputFormat::capture,
                                               InputFormat::hex, InputFormat::automatic};
    const InputFormat format = kFormats[data[0] % 4];
    auto source = source_from_memory(as_string(data + 1, size - 1), "fuzz", format);
    if (source) drain(**source);
}

}  // namespace rtuscope::fuzz
