// The whole live path on a virtual bus: a libmodbus master and the four simulated seed
// devices talk, rtuscope sniffs on a port of its own through the tty source, and every
// transaction the master made must come out decoded and paired with the values the
// devices hold. The recorded capture must decode offline to the same records, and an
// unplugged port must end the run with a clear error.
#include <fcntl.h>
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <termios.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <thread>

#include "framing/crc.hpp"
#include "input/capture_writer.hpp"
#include "recording/recorder.hpp"
#include "input/sources.hpp"
#include "input/tty.hpp"
#include "pipeline.hpp"
#include "profiles/bus.hpp"
#include "sim/sim.hpp"
#include "support.hpp"

namespace rtuscope {
namespace {

using namespace std::chrono_literals;

LineSettings bus_line() {
    LineSettings line;
    line.baud = 38400;  // paced: real gaps, and the test stays quick
    return line;
}

Bus seed_bus() {
    Bus bus;
    EXPECT_TRUE(test::assign_seed_devices(bus));
    return bus;
}

const DecodedValue* value_named(const Record& r, const std::string& name) {
    for (const DecodedValue& v : r.values) {
        if (v.name == name) return &v;
    }
    return nullptr;
}

TEST(Integration, EveryTransactionOfTheMasterIsDecodedAndPaired) {
    const LineSettings line = bus_line();
    auto vbus = sim::VirtualBus::create(6, {line, true});
    ASSERT_TRUE(vbus) << vbus.error().to_string();
    auto devices = sim::start_seed_devices(**vbus, line);
    ASSERT_TRUE(devices) << devices.error().to_string();

    std::atomic<bool> stop{false};
    TtyOptions tty;
    tty.ports = {(*vbus)->port_path(5)};
    tty.line = line;
    tty.stop = &stop;
    auto source = open_tty_source(tty);
    ASSERT_TRUE(source) << source.error().to_string();
    const test::TempDir dir;
    const std::string capture = dir.file("integration.rtucap");
    const SourceInfo header = (*source)->info();
    auto recording = record_capture(std::move(*source), capture, header);
    ASSERT_TRUE(recording);

    constexpr std::size_t kCycles = 3;  // the third cycle writes
    auto master = sim::start_master((*vbus)->port_path(0), line, {}, kCycles, 5);
    ASSERT_TRUE(master) << master.error().to_string();
    std::thread watcher([&] {
        for (int i = 0; i < 3000 && (*master)->cycles() < kCycles; ++i) {
            std::this_thread::sleep_for(10ms);
        }
        std::this_thread::sleep_for(300ms);  // the last answer reaches the sniffer
        stop.store(true);
    });

    const Bus bus = seed_bus();
    PipelineOptions options;
    options.bus = &bus;
    options.live = true;
    test::CollectingSink live;
    const Status status = run_pipeline(**recording, options, live);
    watcher.join();
    ASSERT_TRUE(status) << status.error().to_string();
    recording->reset();
    ASSERT_EQ((*master)->cycles(), kCycles);

    // Each request of the master, in order, is a request record; each answered one is
    // paired with an answer that carries the values libmodbus read.
    const std::vector<sim::MasterEntry> log = (*master)->log();
    ASSERT_FALSE(log.empty());
    std::size_t at = 0;
    for (const sim::MasterEntry& entry : log) {
        while (at < live.records.size() && live.records[at].kind != Kind::request) ++at;
        ASSERT_LT(at, live.records.size()) << "request to slave " << int(entry.slave)
                                           << " function " << int(entry.function) << " missing";
        const Record& request = live.records[at];
        EXPECT_EQ(request.frame.slave(), entry.slave);
        EXPECT_EQ(request.frame.function(), entry.function);
        EXPECT_EQ(request.frame.crc.status, CrcStatus::ok);
        const Record* answer = nullptr;
        for (std::size_t j = at + 1; j < live.records.size(); ++j) {
            if (live.records[j].request_number == request.number) answer = &live.records[j];
        }
        if (entry.answered) {
            ASSERT_NE(answer, nullptr) << "no answer paired with request #" << request.number;
            EXPECT_EQ(answer->frame.crc.status, CrcStatus::ok);
            if (entry.function == 0x03) {
                ASSERT_FALSE(answer->decoded.blocks.empty());
                EXPECT_EQ(answer->decoded.blocks[0].values, entry.values)
                    << "answer #" << answer->number;
            }
        }
        ++at;
    }
    // Decoded in the devices' words, with the values the simulators hold.
    bool saw_voltage = false;
    bool saw_uv = false;
    for (const Record& r : live.records) {
        if (r.kind != Kind::response) continue;
        if (const DecodedValue* v = value_named(r, "voltage");
            v != nullptr && r.frame.slave() == 3) {
            EXPECT_EQ(v->raw, fmt::format("0x{:04X}", (*devices)[2]->holding(0x0000)));
            saw_voltage = true;
        }
        if (const DecodedValue* v = value_named(r, "uv_intensity")) {
            EXPECT_EQ(v->raw, fmt::format("0x{:04X}", (*devices)[0]->holding(0x0000)));
            saw_uv = true;
        }
    }
    EXPECT_TRUE(saw_voltage);
    EXPECT_TRUE(saw_uv);
    // The ZB-UVI485's own FC04 is framed as 8 bytes and paired with its echo.
    bool saw_coefficient = false;
    for (const Record& r : live.records) {
        if (r.frame.slave() == 1 && r.frame.function() == 0x04 && r.kind == Kind::response) {
            EXPECT_EQ(r.decoded.function_name, "Set correction coefficient");
            EXPECT_EQ(r.frame.bytes.size(), 8U);
            saw_coefficient = true;
        }
    }
    EXPECT_TRUE(saw_coefficient);
    for (const Record& r : live.records) {
        EXPECT_NE(r.kind, Kind::noise) << "noise at record #" << r.number;
    }

    // The capture decodes offline to the same records.
    auto offline = open_source(capture, InputFormat::automatic);
    ASSERT_TRUE(offline) << offline.error().to_string();
    PipelineOptions offline_options;
    offline_options.bus = &bus;
    test::CollectingSink again;
    ASSERT_TRUE(run_pipeline(**offline, offline_options, again));
    ASSERT_EQ(again.records.size(), live.records.size());
    for (std::size_t i = 0; i < live.records.size(); ++i) {
        EXPECT_EQ(again.records[i].frame.bytes, live.records[i].frame.bytes) << "record " << i;
        EXPECT_EQ(again.records[i].kind, live.records[i].kind) << "record " << i;
        EXPECT_EQ(again.records[i].request_number, live.records[i].request_number);
        EXPECT_EQ(again.records[i].frame.start, live.records[i].frame.start);
    }
}

TEST(Integration, UnpluggedPortEndsTheRunWithWhatCameBefore) {
    const LineSettings line = bus_line();
    auto vbus = sim::VirtualBus::create(2, {line, true});
    ASSERT_TRUE(vbus) << vbus.error().to_string();
    TtyOptions tty;
    tty.ports = {(*vbus)->port_path(1)};
    tty.line = line;
    auto source = open_tty_source(tty);
    ASSERT_TRUE(source) << source.error().to_string();
    // A master on port 0: one request, then the sniffer's adapter is pulled out.
    const int master = open((*vbus)->port_path(0).c_str(), O_RDWR | O_NOCTTY);
    ASSERT_GE(master, 0);
    termios tio{};
    tcgetattr(master, &tio);
    cfmakeraw(&tio);
    tcsetattr(master, TCSANOW, &tio);
    std::vector<std::uint8_t> request = {0x04, 0x03, 0x00, 0x03, 0x00, 0x0C};
    const std::uint16_t crc = crc16_modbus(request);
    request.push_back(static_cast<std::uint8_t>(crc & 0xFF));
    request.push_back(static_cast<std::uint8_t>(crc >> 8));
    std::thread unplugger([&] {
        std::this_thread::sleep_for(50ms);
        EXPECT_EQ(write(master, request.data(), request.size()),
                  static_cast<ssize_t>(request.size()));
        std::this_thread::sleep_for(300ms);
        (*vbus)->unplug(1);
    });
    test::CollectingSink live;
    PipelineOptions options;
    options.live = true;
    const Status status = run_pipeline(**source, options, live);
    unplugger.join();
    close(master);
    ASSERT_FALSE(status);
    EXPECT_NE(status.error().message.find("was the adapter unplugged?"), std::string::npos)
        << status.error().to_string();
    ASSERT_EQ(live.records.size(), 1U);  // what came before the unplug was decoded
    EXPECT_EQ(live.records[0].frame.bytes, request);
    EXPECT_EQ(live.records[0].kind, Kind::request);
}

}  // namespace
}  // namespace rtuscope
