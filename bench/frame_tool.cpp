// rtuscope_bench_frame: framing + CRC alone, no pairing, decoding or output. Reads the
// whole input into memory first so that only the framer (and, for a capture, the capture
// parser) is timed.
//
//   rtuscope_bench_frame FILE [raw|capture] [repeat]
#include <fmt/format.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <string>

#include "rtuscope/framer.hpp"
#include "rtuscope/sources.hpp"

int main(int argc, char** argv) {
    if (argc < 2) {
        fmt::print(stderr, "usage: rtuscope_bench_frame FILE [raw|capture] [repeat]\n");
        return 2;
    }
    std::ifstream in(argv[1], std::ios::binary);
    const std::string content((std::istreambuf_iterator<char>(in)), {});
    const std::string mode = argc > 2 ? argv[2] : "raw";
    const int repeat = argc > 3 ? std::stoi(argv[3]) : 1;
    const auto format =
        mode == "capture" ? rtuscope::InputFormat::capture : rtuscope::InputFormat::raw;

    double best = 1e300;
    std::uint64_t frames = 0;
    std::uint64_t bad = 0;
    for (int r = 0; r < repeat; ++r) {
        // The copy into the source is not timed.
        auto source = rtuscope::source_from_memory(content, argv[1], format);
        if (!source) {
            fmt::print(stderr, "{}\n", source.error().message);
            return 1;
        }
        frames = 0;
        bad = 0;
        rtuscope::FramerOptions options;
        options.line = (*source)->info().line.value_or(rtuscope::LineSettings{});
        rtuscope::Framer framer(options, [&](const rtuscope::Frame& f) {
            frames += f.cls == rtuscope::RecordClass::frame;
            bad += f.cls == rtuscope::RecordClass::invalid;
        });
        const auto t0 = std::chrono::steady_clock::now();
        rtuscope::Chunk chunk;
        for (;;) {
            auto more = (*source)->next(chunk);
            if (!more.ok() || !*more) break;
            framer.push(chunk);
        }
        framer.finish();
        const double s =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        best = std::min(best, s);
    }
    fmt::print("{} {} bytes, {} frames ok, {} invalid: {:.3f} s, {:.1f} MB/s, {:.2f} M frames/s\n",
               mode, content.size(), frames, bad, best,
               static_cast<double>(content.size()) / best / 1e6,
               static_cast<double>(frames + bad) / best / 1e6);
    return 0;
}
