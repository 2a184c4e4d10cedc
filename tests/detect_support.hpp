// The pieces of a detection on the virtual bus shared by its tests and the matrix tool:
// a bus of the seed devices polled at one setting, and the detector listening on its
// sniffer port, telling the hub each candidate's format (a pseudo-terminal cannot carry
// it).
#pragma once

#include <fmt/format.h>

#include <memory>
#include <string>
#include <vector>

#include "detect/detect.hpp"
#include "input/tty_listener.hpp"
#include "sim/sim.hpp"

namespace rtuscope::test {

inline constexpr std::size_t kSniffer = 5;

inline LineSettings setting(std::uint32_t baud, std::string_view format) {
    LineSettings line = *parse_line_format(format);
    line.baud = baud;
    return line;
}

inline std::string name(const LineSettings& line) {
    return fmt::format("{} {}", line.baud, line.format());
}

inline Result<DetectResult> detect_on(sim::VirtualBus& bus, DetectOptions options) {
    auto listener = TtyListener::open({bus.port_path(kSniffer)}, nullptr);
    if (!listener) return listener.error();
    return detect_line(
        [&](const LineSettings& line, Nanos most, const auto& enough, std::vector<Chunk>& out) {
            bus.set_receiver_format(kSniffer, line.data_bits, line.parity);
            return (*listener)->listen(line, most, enough, out);
        },
        options);
}

// The four seed devices polled without end at `line`; `error` says what did not start.
struct SeedBus {
    explicit SeedBus(const LineSettings& line, int pause_ms = 20) {
        auto created = sim::VirtualBus::create(6, {line, true});
        if (!created) {
            error = created.error().to_string();
            return;
        }
        bus = std::move(*created);
        auto started = sim::start_seed_devices(*bus, line);
        if (!started) {
            error = started.error().to_string();
            return;
        }
        devices = std::move(*started);
        auto polling = sim::start_master(bus->port_path(0), line, {}, 0, pause_ms);
        if (!polling) {
            error = polling.error().to_string();
            return;
        }
        master = std::move(*polling);
    }
    ~SeedBus() {
        if (master) master->stop();
    }
    SeedBus(const SeedBus&) = delete;
    SeedBus& operator=(const SeedBus&) = delete;

    std::unique_ptr<sim::VirtualBus> bus;
    std::vector<std::unique_ptr<sim::Device>> devices;
    std::unique_ptr<sim::Master> master;
    std::string error;
};

}  // namespace rtuscope::test
