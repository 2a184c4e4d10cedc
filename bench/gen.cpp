// rtuscope_bench_gen: writes a large realistic capture (bench/traffic.hpp) in the native
// capture format and the same bytes as a raw binary dump; or, with --garbage, random
// bytes as a raw dump, or as a capture of one byte a line.
//
//   rtuscope_bench_gen [--frames N] [--seed S] [--baud B] [--all-slaves N] [--per-byte]
//                      [--capture FILE] [--raw FILE]
//   rtuscope_bench_gen --garbage BYTES [--seed S] [--baud B] [--raw FILE] [--capture FILE]
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>

#include "input/capture_writer.hpp"
#include "traffic.hpp"

namespace {

struct FileCloser {
    void operator()(std::FILE* f) const { std::fclose(f); }
};
using File = std::unique_ptr<std::FILE, FileCloser>;

File open_out(const std::string& path) {
    if (path.empty()) return nullptr;
    File f(std::fopen(path.c_str(), "wb"));
    if (!f) {
        fmt::print(stderr, "rtuscope_bench_gen: cannot create {}: {}\n", path,
                   std::strerror(errno));
        std::exit(1);
    }
    return f;
}

}  // namespace

int main(int argc, char** argv) {
    rtuscope::bench::TrafficOptions options;
    std::string capture_path;
    std::string raw_path;
    CLI::App app{
        "rtuscope_bench_gen: writes realistic traffic of the four seed devices and "
        "standard devices (bench/traffic.hpp) as a native capture and/or a raw dump"};
    auto* frames = app.add_option("--frames", options.frames, "frames to generate")
                       ->capture_default_str()
                       ->check(CLI::Range(std::uint64_t{1}, std::uint64_t{10'000'000'000}));
    app.add_option("--seed", options.seed, "seed of the traffic's random choices")
        ->capture_default_str();
    app.add_option("--baud", options.baud, "line speed the timing follows")
        ->capture_default_str()
        ->check(CLI::Range(std::uint32_t{300}, std::uint32_t{4'000'000}));
    auto* all_slaves =
        app.add_option("--all-slaves", options.all_slaves_functions,
                       "instead of the mix, every slave 1-247 asked functions 1..N in turn, each "
                       "answered by an exception (the largest statistics: 247 x N rows)")
            ->check(CLI::Range(1, 127));
    app.add_flag("--per-byte", options.per_byte,
                 "each byte on a line of its own, timed when it ended (a logic analyser's "
                 "export), instead of a USB adapter's batches");
    app.add_option("--capture", capture_path, "native capture to write");
    app.add_option("--raw", raw_path, "raw dump (the bytes alone) to write");
    std::uint64_t garbage_bytes = 0;
    app.add_option("--garbage", garbage_bytes,
                   "instead of traffic, this many random bytes (from --seed): into --raw, "
                   "and into --capture one a line, back to back at --baud")
        ->check(CLI::Range(std::uint64_t{1}, std::uint64_t{1'000'000'000}))
        ->excludes(frames)
        ->excludes(all_slaves)
        ->excludes("--per-byte");
    try {
        app.parse(argc, argv);
        if (capture_path.empty() && raw_path.empty()) {
            throw CLI::RequiredError("--capture FILE or --raw FILE (nothing to write)");
        }
    } catch (const CLI::ParseError& e) {
        return app.exit(e);
    }
    File capture = open_out(capture_path);
    File raw = open_out(raw_path);
    if (capture) fmt::print(capture.get(), "{}", rtuscope::bench::capture_header(options));
    auto write_chunk = [&](const rtuscope::Chunk& c) {
        if (capture) {
            const std::string line = rtuscope::capture_line(c);
            std::fwrite(line.data(), 1, line.size(), capture.get());
        }
        if (raw) std::fwrite(c.bytes.data(), 1, c.bytes.size(), raw.get());
    };
    if (garbage_bytes != 0) {
        const auto bytes = rtuscope::bench::garbage(garbage_bytes, options.seed);
        rtuscope::bench::garbage_per_byte(bytes, options.baud, write_chunk);
        fmt::print(stderr, "{} bytes of garbage\n", bytes.size());
        return 0;
    }
    const auto stats = rtuscope::bench::generate_traffic(options, write_chunk);
    fmt::print(stderr, "{} frames, {} bytes, {} chunks at {} baud\n", stats.frames, stats.bytes,
               stats.chunks, options.baud);
    return 0;
}
