// Writes a file through OutputFile a line at a time, as a run writes its capture, to each
// output given (compressed by its extension: .gz, .zst), and reports the size on disk, the
// ratio and the speed of writing. scripts/bench runs it on the bench capture; the tests
// make their compressed captures with it.
//   rtuscope_bench_compress INPUT --out FILE... [--block-bytes N] [--repeat N]
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include "util/output_file.hpp"
#include "util/time.hpp"

namespace {

const char* compression_label(rtuscope::Compression compression) {
    switch (compression) {
        case rtuscope::Compression::gzip:
            return "gzip";
        case rtuscope::Compression::zstd:
            return "zstd";
        case rtuscope::Compression::none:
            break;
    }
    return "plain";
}

// Writes `text` a line at a time to `path`; the seconds it took, or a message.
rtuscope::Result<double> write_lines(const std::string& text, const std::string& path,
                                     const rtuscope::OutputFileOptions& options,
                                     std::uint64_t& size) {
    const rtuscope::Nanos start = rtuscope::clock_ns(CLOCK_MONOTONIC);
    auto file = rtuscope::create_output_file(path, options);
    if (!file) return file.error();
    std::string_view rest = text;
    while (!rest.empty()) {
        const std::size_t end = std::min(rest.find('\n'), rest.size() - 1) + 1;
        if (auto s = (*file)->write(rest.substr(0, end)); !s) return s.error();
        rest.remove_prefix(end);
    }
    if (auto s = (*file)->close(); !s) return s.error();
    size = (*file)->size();
    return static_cast<double>(rtuscope::clock_ns(CLOCK_MONOTONIC) - start) / 1e9;
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"Writes a file through OutputFile a line at a time; reports ratio and speed"};
    std::string input;
    std::vector<std::string> outputs;
    std::size_t block_bytes = rtuscope::OutputFileOptions{}.block_bytes;
    int repeat = 1;
    app.add_option("INPUT", input, "File to write")->required()->check(CLI::ExistingFile);
    app.add_option("--out", outputs, "Output files (.gz, .zst or plain)")->required();
    app.add_option("--block-bytes", block_bytes, "Uncompressed bytes a block")
        ->check(CLI::Range(std::size_t{1}, std::size_t{1} << 30));
    app.add_option("--repeat", repeat, "Runs of each output; the fastest is reported")
        ->check(CLI::Range(1, 100));
    CLI11_PARSE(app, argc, argv);

    std::ifstream in(input, std::ios::binary);
    std::ostringstream buffer;
    buffer << in.rdbuf();
    const std::string text = buffer.str();
    if (!in || text.empty()) {
        fmt::print(stderr, "rtuscope_bench_compress: {}: cannot read, or empty\n", input);
        return 1;
    }
    for (const std::string& path : outputs) {
        rtuscope::OutputFileOptions options;
        options.compression = rtuscope::compression_for(path);
        options.block_bytes = block_bytes;
        double best = 0;
        std::uint64_t size = 0;
        for (int i = 0; i < repeat; ++i) {
            rtuscope::Result<double> secs = write_lines(text, path, options, size);
            if (!secs) {
                fmt::print(stderr, "rtuscope_bench_compress: {}\n", secs.error().to_string());
                return 1;
            }
            best = i == 0 ? *secs : std::min(best, *secs);
        }
        fmt::print("{:5} {} -> {} bytes: ratio {:.2f}, written at {:.1f} MB/s (input)\n",
                   compression_label(options.compression), text.size(), size,
                   static_cast<double>(text.size()) /
                       static_cast<double>(std::max<std::uint64_t>(size, 1)),
                   best > 0 ? static_cast<double>(text.size()) / best / 1e6 : 0.0);
    }
    return 0;
}
