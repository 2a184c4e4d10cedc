// Replays, under the normal (and the sanitizer) build, every seed of the fuzz targets and
// every input a fuzzer ever crashed on (tests/fuzz_regressions/TARGET/, kept by
// scripts/fuzz). Each must run to its end: a crash, a sanitizer report or a hang fails.
// The seeds are found as scripts/fuzz finds them (fuzz/README.md): the repository files
// fuzz/corpus/TARGET.list names, and the files of fuzz/corpus/TARGET/.
#include <glob.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include "../fuzz/targets.hpp"

namespace rtuscope {
namespace {

namespace fs = std::filesystem;

using Target = void (*)(const std::uint8_t*, std::size_t);

std::string read_file(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void run_bytes(Target run, const std::string& bytes) {
    run(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
}

// fuzz_capture_reader takes its input's first byte as the format (targets.hpp):
// scripts/fuzz writes each listed file behind its FORMAT's byte.
int format_byte(const std::string& format) {
    if (format == "raw") return 0;
    if (format == "capture") return 1;
    if (format == "hex") return 2;
    if (format == "auto") return 3;
    return -1;
}

// fuzz/corpus/TARGET.list: one repository path (or glob) a line; for fuzz_capture_reader
// FORMAT PATH. A line that matches no file fails, as it stops scripts/fuzz.
std::size_t replay_list(const std::string& target, Target run) {
    const fs::path root(RTUSCOPE_SOURCE_DIR);
    std::ifstream list(root / "fuzz" / "corpus" / (target + ".list"));
    if (!list) return 0;
    std::size_t replayed = 0;
    std::string line;
    while (std::getline(list, line)) {
        std::istringstream fields(line);
        std::string first;
        std::string second;
        if (!(fields >> first) || first[0] == '#') continue;
        std::string prefix;
        std::string pattern = first;
        if (target == "fuzz_capture_reader") {
            const int byte = format_byte(first);
            if (byte < 0 || !(fields >> second)) {
                ADD_FAILURE() << target << ".list: expected FORMAT PATH: " << line;
                continue;
            }
            prefix.assign(1, static_cast<char>(byte));
            pattern = second;
        }
        glob_t matches{};
        const std::string full = (root / pattern).string();
        const int rc = ::glob(full.c_str(), 0, nullptr, &matches);
        std::size_t found = 0;
        for (std::size_t i = 0; rc == 0 && i < matches.gl_pathc; ++i) {
            const fs::path path(matches.gl_pathv[i]);
            if (!fs::is_regular_file(path)) continue;
            SCOPED_TRACE(first + " " + path.string());
            run_bytes(run, prefix + read_file(path));
            ++found;
        }
        ::globfree(&matches);
        EXPECT_GT(found, 0U) << target << ".list: " << line << " matches no file";
        replayed += found;
    }
    return replayed;
}

std::size_t replay(const std::string& target, Target run) {
    std::size_t replayed = replay_list(target, run);
    for (const char* where : {"fuzz/corpus/", "tests/fuzz_regressions/"}) {
        const fs::path dir = fs::path(RTUSCOPE_SOURCE_DIR) / where / target;
        if (!fs::is_directory(dir)) continue;
        for (const auto& entry : fs::directory_iterator(dir)) {
            if (!entry.is_regular_file()) continue;
            SCOPED_TRACE(entry.path().string());
            run_bytes(run, read_file(entry.path()));
            ++replayed;
        }
    }
    return replayed;
}

TEST(FuzzRegressions, Pipeline) {
    EXPECT_GT(replay("fuzz_pipeline", fuzz::pipeline), 0U);
}
TEST(FuzzRegressions, ProfileLoader) {
    EXPECT_GT(replay("fuzz_profile_loader", fuzz::profile_loader), 0U);
}
TEST(FuzzRegressions, PcapReader) {
    EXPECT_GT(replay("fuzz_pcap_reader", fuzz::pcap_reader), 0U);
}
TEST(FuzzRegressions, CaptureReader) {
    EXPECT_GT(replay("fuzz_capture_reader", fuzz::capture_reader), 0U);
}

}  // namespace
}  // namespace rtuscope
