// A virtual bus of the seed devices polled at one setting, for CLI tests that sniff a port
// of it as a user sniffs an adapter: prints the sniffer port's path, then runs until its
// standard input closes.
// Usage: rtuscope_seed_bus BAUD FORMAT
#include <fmt/format.h>

#include <cstdio>
#include <iostream>
#include <string>

#include "detect_support.hpp"

using namespace rtuscope;

int main(int argc, char** argv) {
    if (argc != 3) {
        fmt::print(stderr, "usage: rtuscope_seed_bus BAUD FORMAT\n");
        return 2;
    }
    auto line = parse_line_settings(fmt::format("{} {}", argv[1], argv[2]));
    if (!line) {
        fmt::print(stderr, "{}\n", line.error().to_string());
        return 2;
    }
    test::SeedBus seed(*line);
    if (!seed.error.empty()) {
        fmt::print(stderr, "{}\n", seed.error);
        return 1;
    }
    fmt::print("{}\n", seed.bus->port_path(test::kSniffer));
    std::fflush(stdout);
    std::string ignored;
    while (std::getline(std::cin, ignored)) {
    }
    return 0;
}
