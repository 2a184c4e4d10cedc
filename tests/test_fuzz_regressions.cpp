// Replays, under the normal (and the sanitizer) build, every seed of the fuzz corpora and
// every input a fuzzer ever crashed on (tests/fuzz_regressions/TARGET/, kept by
// scripts/fuzz). Each must run to its end: a crash, a sanitizer report or a hang fails.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "../fuzz/targets.hpp"

namespace rtuscope {
namespace {

namespace fs = std::filesystem;

using Target = void (*)(const std::uint8_t*, std::size_t);

std::size_t replay(const std::string& target, Target run) {
    std::size_t replayed = 0;
    for (const char* where : {"fuzz/corpus/", "tests/fuzz_regressions/"}) {
        const fs::path dir = fs::path(RTUSCOPE_SOURCE_DIR) / where / target;
        if (!fs::is_directory(dir)) continue;
        for (const auto& entry : fs::directory_iterator(dir)) {
            if (!entry.is_regular_file()) continue;
            std::ifstream in(entry.path(), std::ios::binary);
            const std::string bytes((std::istreambuf_iterator<char>(in)),
                                    std::istreambuf_iterator<char>());
            SCOPED_TRACE(entry.path().string());
            run(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
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
