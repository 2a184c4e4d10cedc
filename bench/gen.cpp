// rtuscope_bench_gen: writes a large realistic capture (bench/traffic.hpp) in the native
// capture format and the same bytes as a raw binary dump.
//
//   rtuscope_bench_gen [--frames N] [--seed S] [--baud B] [--capture FILE] [--raw FILE]
#include <fmt/format.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>

#include "rtuscope/capture_writer.hpp"
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
    for (int i = 1; i + 1 < argc; i += 2) {
        const std::string key = argv[i];
        const char* value = argv[i + 1];
        if (key == "--frames") {
            options.frames = std::strtoull(value, nullptr, 10);
        } else if (key == "--seed") {
            options.seed = std::strtoull(value, nullptr, 10);
        } else if (key == "--baud") {
            options.baud = static_cast<std::uint32_t>(std::strtoul(value, nullptr, 10));
        } else if (key == "--capture") {
            capture_path = value;
        } else if (key == "--raw") {
            raw_path = value;
        } else {
            fmt::print(stderr, "rtuscope_bench_gen: unknown option {}\n", key);
            return 2;
        }
    }
    if (argc % 2 == 0 || options.baud == 0) {
        fmt::print(stderr,
                   "usage: rtuscope_bench_gen [--frames N] [--seed S] [--baud B] "
                   "[--capture FILE] [--raw FILE]\n");
        return 2;
    }
    File capture = open_out(capture_path);
    File raw = open_out(raw_path);
    if (capture)
        fmt::print(capture.get(), "# rtuscope capture v1\n# serial {} 8N1\n", options.baud);
    const auto stats = rtuscope::bench::generate_traffic(options, [&](const rtuscope::Chunk& c) {
        if (capture) {
            const std::string line = rtuscope::capture_line(c);
            std::fwrite(line.data(), 1, line.size(), capture.get());
        }
        if (raw) std::fwrite(c.bytes.data(), 1, c.bytes.size(), raw.get());
    });
    fmt::print(stderr, "{} frames, {} bytes, {} chunks at {} baud\n", stats.frames, stats.bytes,
               stats.chunks, options.baud);
    return 0;
}
