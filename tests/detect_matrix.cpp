// Detection at every rate detect tries by default and every format, on the virtual bus
// of the seed devices: one line per setting with what was chosen, the settings that read
// the line alike, the confidence and the seconds listened. Minutes of listening, so it is
// a tool (scripts/detect-matrix), not a ctest test; docs/detect.md states its result.
#include <fmt/format.h>

#include <chrono>
#include <cstdio>

#include "detect_support.hpp"

using namespace rtuscope;

int main() {
    int wrong = 0;
    fmt::print("{:<12} {:<12} {:<22} {:<10} {:>7}\n", "line", "chosen", "alike", "confidence",
               "seconds");
    for (const std::uint32_t baud : default_bauds()) {
        for (const char* format : {"8N1", "8E1", "8O1", "8N2"}) {
            const LineSettings truth = test::setting(baud, format);
            test::SeedBus seed(truth);
            if (!seed.error.empty()) {
                fmt::print(stderr, "{}: {}\n", test::name(truth), seed.error);
                return 1;
            }
            const auto start = std::chrono::steady_clock::now();
            auto result = test::detect_on(*seed.bus, DetectOptions{});
            const double seconds =
                std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
            if (!result) {
                fmt::print(stderr, "{}: {}\n", test::name(truth), result.error().to_string());
                return 1;
            }
            std::string alike;
            bool among = false;
            for (std::size_t i = 0; i < result->alike; ++i) {
                if (!alike.empty()) alike += ',';
                alike += result->ranked[i].line.format();
                among = among || test::name(result->ranked[i].line) == test::name(truth);
            }
            const bool right = among && result->chosen.baud == baud;
            wrong += right ? 0 : 1;
            fmt::print("{:<12} {:<12} {:<22} {:<10} {:>7.1f}{}\n", test::name(truth),
                       result->alike == 0 ? std::string("none") : test::name(result->chosen),
                       alike, result->confidence, seconds, right ? "" : "  WRONG");
            std::fflush(stdout);
        }
    }
    fmt::print("{} of {} settings detected wrongly\n", wrong, default_bauds().size() * 4);
    return wrong == 0 ? 0 : 1;
}
