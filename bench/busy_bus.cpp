// A busy virtual bus for benchmarking a sniffer from outside its process, until SIGINT or
// SIGTERM; it prints the path of the port a sniffer opens first. Either the four seed
// devices simulated, their master polling them with no pause (their own slow answers and
// timeouts set the pace), or, with --capture, a capture's traffic played onto the line
// at its own pace, over and over: rtuscope_bench_gen's is as dense as its baud rate
// allows.
// --speed plays it faster (its silences shorter), up to what the line carries.
//   rtuscope_bench_busy_bus [--baud N] [--capture FILE [--speed F]]
#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <array>
#include <csignal>
#include <cstdio>
#include <memory>
#include <thread>
#include <vector>

#include <fcntl.h>
#include <unistd.h>

#include <chrono>

#include "input/sources.hpp"
#include "sim/sim.hpp"

namespace {
volatile std::sig_atomic_t g_stopped = 0;
extern "C" void on_signal(int /*signal*/) { g_stopped = 1; }
}  // namespace

int main(int argc, char** argv) {
    using namespace rtuscope;
    CLI::App app{"A virtual bus as busy as its baud rate allows, for benchmarks"};
    std::uint32_t baud = 115200;
    std::string capture;
    app.add_option("--baud", baud, "Line speed (default 115200)");
    double speed = 1;
    app.add_option("--capture", capture, "Play this capture onto the line instead");
    app.add_option("--speed", speed, "Play it this many times as fast (default 1)")
        ->check(CLI::PositiveNumber);
    CLI11_PARSE(app, argc, argv);

    LineSettings line;
    line.baud = baud;
    auto bus = sim::VirtualBus::create(6, {line, true});
    if (!bus) return fmt::print(stderr, "{}\n", bus.error().to_string()), 1;
    std::signal(SIGINT, on_signal);
    std::signal(SIGTERM, on_signal);
    if (!capture.empty()) {
        fmt::print("{}\n", (*bus)->port_path(5));
        std::fflush(stdout);
        const int fd = ::open((*bus)->port_path(0).c_str(), O_WRONLY | O_NOCTTY);
        if (fd < 0) return fmt::print(stderr, "cannot open the bus's port\n"), 1;
        std::this_thread::sleep_for(std::chrono::seconds(1));
        const auto start = std::chrono::steady_clock::now();
        Nanos offset = 0;  // each round's times after the last one's
        while (g_stopped == 0) {
            auto source = open_source(capture, InputFormat::capture);
            if (!source) return fmt::print(stderr, "{}\n", source.error().to_string()), 1;
            Chunk chunk;
            Nanos first = kNoTime;
            Nanos last = 0;
            for (;;) {
                Result<bool> more = (*source)->next(chunk);
                if (!more.ok() || !*more || g_stopped != 0) break;
                if (!has_time(first)) first = chunk.time;
                last = chunk.time - first;
                std::this_thread::sleep_until(
                    start + std::chrono::nanoseconds(static_cast<Nanos>(
                                static_cast<double>(offset + last) / speed)));
                if (::write(fd, chunk.bytes.data(), chunk.bytes.size()) < 0) break;
            }
            offset += last + 10'000'000;
        }
        ::close(fd);
        return 0;
    }
    auto devices = sim::start_seed_devices(**bus, line);
    if (!devices) return fmt::print(stderr, "{}\n", devices.error().to_string()), 1;
    fmt::print("{}\n", (*bus)->port_path(5));
    std::fflush(stdout);
    // The sniffer opens the port first; then the master starts.
    std::this_thread::sleep_for(std::chrono::seconds(1));
    auto master = sim::start_master((*bus)->port_path(0), line, {}, 0, 0);
    if (!master) return fmt::print(stderr, "{}\n", master.error().to_string()), 1;
    while (g_stopped == 0) std::this_thread::sleep_for(std::chrono::milliseconds(50));
    (*master)->stop();
    return 0;
}
