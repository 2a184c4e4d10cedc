// Detection end to end through the real tty code: a virtual bus of the seed devices at
// one setting, the detector listening on a pseudo-terminal of it at each candidate
// setting. The hub delivers what a UART set to the candidate receives from the bus's
// true setting (garbage at a wrong rate, the parity bit read as a stop bit ...); a
// pseudo-terminal cannot carry parity settings or error marks, so the test tells the hub
// each candidate's format and the port reports no errors, as some adapters' drivers do.
// Then the setting chosen must decode the line: every frame with a valid CRC.
#include <fcntl.h>
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <termios.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <random>
#include <thread>

#include "detect/detect.hpp"
#include "input/tty.hpp"
#include "input/tty_listener.hpp"
#include "pipeline.hpp"
#include "sim/sim.hpp"
#include "detect_support.hpp"
#include "support.hpp"

namespace rtuscope {
namespace {

using namespace std::chrono_literals;
using test::detect_on;
using test::kSniffer;
using test::name;
using test::SeedBus;
using test::setting;

// Sniffs the bus for `seconds` at `line`: the records.
std::vector<Record> sniff(sim::VirtualBus& bus, const LineSettings& line, Nanos seconds) {
    bus.set_receiver_format(kSniffer, line.data_bits, line.parity);
    TtyOptions tty;
    tty.ports = {bus.port_path(kSniffer)};
    tty.line = line;
    tty.duration = seconds;
    auto source = open_tty_source(tty);
    EXPECT_TRUE(source) << source.error().to_string();
    if (!source) return {};
    PipelineOptions options;
    options.live = true;
    test::CollectingSink sink;
    EXPECT_TRUE(run_pipeline(**source, options, sink));
    return sink.records;
}

// The detector's verdict, then a sniff at it: its frames all have a valid CRC.
// The sniff that follows lasts `sniff_for` and must hear at least `frames` good frames.
void expect_detected(sim::VirtualBus& bus, const LineSettings& truth, std::size_t frames = 4,
                     Nanos sniff_for = 3 * kNanosPerSecond) {
    DetectOptions options;
    options.bauds = {9600, 19200, 115200, 38400};
    auto result = detect_on(bus, options);
    ASSERT_TRUE(result) << result.error().to_string();
    const std::string report = format_detect_result(*result);
    ASSERT_GE(result->alike, 1U) << report;
    // The true setting reads the line as well as any other.
    bool among = false;
    for (std::size_t i = 0; i < result->alike; ++i) among = among || name(result->ranked[i].line) == name(truth);
    EXPECT_TRUE(among) << name(truth) << " is not among the best:\n" << report;
    EXPECT_EQ(result->chosen.baud, truth.baud) << report;
    // Where the characters' length or garbage tells the formats apart, the choice is it.
    if (truth.format() == "8N1" || truth.format() == "8E1") {
        EXPECT_EQ(result->chosen.format(), truth.format()) << report;
    }
    const std::vector<Record> records = sniff(bus, result->chosen, sniff_for);
    std::size_t good = 0;
    for (const Record& r : records) {
        // A sniffer that opens the port mid-frame hears the rest of one; the frame on the
        // line when it stops is cut.
        if (r.kind == Kind::noise || r.number == 1 || r.notes.has(note_id::cut_by_stop)) continue;
        EXPECT_EQ(r.frame.crc.status, CrcStatus::ok)
            << "at " << name(result->chosen) << ": record " << r.number << " of " << records.size()
            << ", " << to_string(r.kind) << ", " << r.frame.bytes.size() << " bytes: "
            << fmt::format("{:02X}", fmt::join(r.frame.bytes, " "));
        if (r.frame.crc.status == CrcStatus::ok) ++good;
    }
    EXPECT_GE(good, frames) << "at " << name(result->chosen) << ": " << records.size() << " records\n" << report;
}

struct LineCase {
    std::uint32_t baud;
    const char* format;
};

class DetectSeedBus : public testing::TestWithParam<LineCase> {};

TEST_P(DetectSeedBus, FindsTheSettingsAndTheChoiceDecodesTheLine) {
    const LineSettings truth = setting(GetParam().baud, GetParam().format);
    SeedBus seed(truth);
    ASSERT_TRUE(seed.error.empty()) << seed.error;
    expect_detected(*seed.bus, truth);
}

std::string case_name(const testing::TestParamInfo<LineCase>& info) {
    return fmt::format("{}_{}", info.param.baud, info.param.format);
}

INSTANTIATE_TEST_SUITE_P(ThreeRatesFourFormats, DetectSeedBus,
                         testing::Values(LineCase{9600, "8N1"}, LineCase{9600, "8E1"},
                                         LineCase{9600, "8O1"}, LineCase{9600, "8N2"},
                                         LineCase{19200, "8N1"}, LineCase{19200, "8E1"},
                                         LineCase{19200, "8O1"}, LineCase{19200, "8N2"},
                                         LineCase{115200, "8N1"}, LineCase{115200, "8E1"},
                                         LineCase{115200, "8O1"}, LineCase{115200, "8N2"}),
                         case_name);

TEST(DetectVirtualBus, OneSlaveOnly) {
    const LineSettings truth = setting(19200, "8E1");
    auto bus = sim::VirtualBus::create(6, {truth, true});
    ASSERT_TRUE(bus);
    auto device = sim::start_device("pdu485", 3, (*bus)->port_path(3), truth);
    ASSERT_TRUE(device) << device.error().to_string();
    auto master = sim::start_master((*bus)->port_path(0), truth, {}, 0, 20);
    ASSERT_TRUE(master);
    // The master waits in vain for the three devices that are not there: a transaction
    // every few seconds.
    expect_detected(**bus, truth, 2, 8 * kNanosPerSecond);
    (*master)->stop();
}

TEST(DetectVirtualBus, ASlowPoll) {
    // A request every half second or so (and the relay's slow answers).
    const LineSettings truth = setting(9600, "8N1");
    SeedBus seed(truth, 500);
    ASSERT_TRUE(seed.error.empty()) << seed.error;
    expect_detected(*seed.bus, truth, 2, 5 * kNanosPerSecond);
}

TEST(DetectVirtualBus, AQuietLineIsReportedQuiet) {
    auto bus = sim::VirtualBus::create(6, {setting(9600, "8N1"), true});
    ASSERT_TRUE(bus);
    DetectOptions options;
    options.quiet_wait = 2 * kNanosPerSecond;
    options.max_dwell = kNanosPerSecond;
    auto result = detect_on(**bus, options);
    ASSERT_TRUE(result) << result.error().to_string();
    EXPECT_TRUE(result->quiet);
    EXPECT_EQ(result->alike, 0U);
}

// Detection never leaves its mark on the port: the settings it found are put back.
TEST(DetectVirtualBus, ThePortKeepsTheSettingsItHad) {
    const LineSettings truth = setting(9600, "8N1");
    SeedBus seed(truth);
    ASSERT_TRUE(seed.error.empty()) << seed.error;
    const std::string port = seed.bus->port_path(kSniffer);
    const int fd = open(port.c_str(), O_RDONLY | O_NOCTTY | O_NONBLOCK);
    ASSERT_GE(fd, 0);
    termios before{};
    ASSERT_EQ(tcgetattr(fd, &before), 0);
    cfsetispeed(&before, B4800);
    cfsetospeed(&before, B4800);
    before.c_cflag |= CSTOPB;
    before.c_lflag |= ICANON;
    ASSERT_EQ(tcsetattr(fd, TCSANOW, &before), 0);
    ASSERT_EQ(tcgetattr(fd, &before), 0);
    DetectOptions options;
    options.bauds = {9600, 19200};
    auto result = detect_on(*seed.bus, options);
    ASSERT_TRUE(result) << result.error().to_string();
    EXPECT_EQ(name(result->chosen), "9600 8N1");
    termios after{};
    ASSERT_EQ(tcgetattr(fd, &after), 0);
    close(fd);
    EXPECT_EQ(cfgetispeed(&after), B4800);
    EXPECT_EQ(after.c_cflag, before.c_cflag);
    EXPECT_EQ(after.c_iflag, before.c_iflag);
    EXPECT_EQ(after.c_lflag, before.c_lflag);
}

TEST(DetectVirtualBus, HeavyNoiseStillRanksTheRightSettingFirst) {
    const LineSettings truth = setting(19200, "8N1");
    SeedBus seed(truth);
    ASSERT_TRUE(seed.error.empty()) << seed.error;
    // Bursts of random bytes from another port, as much noise as traffic.
    std::atomic<bool> stop{false};
    std::thread noise([&] {
        const int fd = open(seed.bus->port_path(4).c_str(), O_WRONLY | O_NOCTTY);
        if (fd < 0) return;
        std::mt19937 random(3);
        while (!stop) {
            std::uint8_t burst[12];
            for (auto& b : burst) b = static_cast<std::uint8_t>(random());
            [[maybe_unused]] const auto n = write(fd, burst, sizeof burst);
            std::this_thread::sleep_for(15ms);
        }
        close(fd);
    });
    DetectOptions options;
    options.bauds = {9600, 19200, 115200};
    auto result = detect_on(*seed.bus, options);
    stop = true;
    noise.join();
    ASSERT_TRUE(result) << result.error().to_string();
    ASSERT_GE(result->alike, 1U) << format_detect_result(*result);
    // 8N2 reads 8N1 traffic byte for byte (a UART checks one stop bit): where the reads
    // are too coarse to time characters, only the noise's luck ranks them.
    EXPECT_EQ(result->chosen.baud, truth.baud) << format_detect_result(*result);
    EXPECT_TRUE(result->chosen.format() == "8N1" || result->chosen.format() == "8N2")
        << format_detect_result(*result);
}

}  // namespace
}  // namespace rtuscope
