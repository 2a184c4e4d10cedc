// Synthetic but realistic Modbus RTU traffic for the benchmarks: a master polling the four
// seed devices (with their quirks) and standard devices, as a USB adapter hands it over.
// Deterministic for a given seed on every platform (own PRNG, no <random> distributions).
#pragma once

#include <cstdint>
#include <functional>

#include "rtuscope/chunk.hpp"

namespace rtuscope::bench {

struct TrafficOptions {
    std::uint64_t frames = 1'000'000;  // requests + answers (noise runs not counted)
    std::uint64_t seed = 1;
    std::uint32_t baud = 115200;  // 8N1
};

struct TrafficStats {
    std::uint64_t frames = 0;
    std::uint64_t bytes = 0;
    std::uint64_t chunks = 0;
};

// Calls `on_chunk` for every chunk in time order. Chunks carry the time their last byte
// was handed over, like `rtuscope sniff -w` records them.
TrafficStats generate_traffic(const TrafficOptions& options,
                              const std::function<void(const Chunk&)>& on_chunk);

}  // namespace rtuscope::bench
