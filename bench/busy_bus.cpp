// A busy virtual bus for benchmarking a sniffer from outside its process: the four seed
// devices simulated on a paced virtual bus, their master polling them with no pause (as
// fast as the line allows), until stopped. Prints the path of the port a sniffer opens,
// then runs until SIGINT or SIGTERM.
//   rtuscope_bench_busy_bus [--baud N]
#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <array>
#include <csignal>
#include <cstdio>
#include <memory>
#include <thread>
#include <vector>

#include "sim/sim.hpp"

namespace {
volatile std::sig_atomic_t g_stopped = 0;
extern "C" void on_signal(int /*signal*/) { g_stopped = 1; }
}  // namespace

int main(int argc, char** argv) {
    using namespace rtuscope;
    CLI::App app{"A virtual bus as busy as its baud rate allows, for benchmarks"};
    std::uint32_t baud = 115200;
    app.add_option("--baud", baud, "Line speed (default 115200)");
    CLI11_PARSE(app, argc, argv);

    LineSettings line;
    line.baud = baud;
    auto bus = sim::VirtualBus::create(6, {line, true});
    if (!bus) return fmt::print(stderr, "{}\n", bus.error().to_string()), 1;
    const std::array<const char*, 4> kinds = {"zb-uvi485", "sensor-analyser", "pdu485",
                                              "zyi-relay"};
    std::vector<std::unique_ptr<sim::Device>> devices;
    for (std::size_t i = 0; i < kinds.size(); ++i) {
        auto device = sim::start_device(kinds[i], static_cast<std::uint8_t>(i + 1),
                                        (*bus)->port_path(i + 1), line);
        if (!device) return fmt::print(stderr, "{}\n", device.error().to_string()), 1;
        devices.push_back(std::move(*device));
    }
    std::signal(SIGINT, on_signal);
    std::signal(SIGTERM, on_signal);
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
