// The simulator: the virtual bus's delivery, pacing and unplugging, and the master polling
// the four simulated seed devices over it.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <thread>
#include <vector>

#include "framing/crc.hpp"
#include "input/tty_baud.hpp"
#include "sim/sim.hpp"
#include "sim/uart_model.hpp"

// The devices' frame splitter is private to the simulator.
#include "sim/sim_util.hpp"

namespace rtuscope::sim {
namespace {

using Bytes = std::vector<std::uint8_t>;
using Clock = std::chrono::steady_clock;

// A port opened the way a sniffer would: raw, non-blocking.
class PortFd {
  public:
    explicit PortFd(const std::string& path)
        : fd_(::open(path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC)) {
        if (fd_ >= 0) {
            termios tio{};
            ::tcgetattr(fd_, &tio);
            ::cfmakeraw(&tio);
            ::tcsetattr(fd_, TCSANOW, &tio);
        }
    }
    ~PortFd() {
        if (fd_ >= 0) ::close(fd_);
    }
    PortFd(const PortFd&) = delete;
    PortFd& operator=(const PortFd&) = delete;
    [[nodiscard]] int fd() const { return fd_; }

    void write(const Bytes& bytes) const {
        ASSERT_EQ(::write(fd_, bytes.data(), bytes.size()), static_cast<ssize_t>(bytes.size()));
    }

    // Up to `want` bytes, waiting at most `timeout` for them.
    [[nodiscard]] Bytes read(std::size_t want, std::chrono::milliseconds timeout) const {
        Bytes got;
        const auto deadline = Clock::now() + timeout;
        while (got.size() < want) {
            const auto left =
                std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
            if (left.count() <= 0) break;
            pollfd p{fd_, POLLIN, 0};
            if (::poll(&p, 1, static_cast<int>(left.count())) <= 0) break;
            std::uint8_t buf[256];
            const ssize_t n = ::read(fd_, buf, sizeof buf);
            if (n <= 0) break;
            got.insert(got.end(), buf, buf + n);
        }
        return got;
    }

  private:
    int fd_;
};

Bytes with_crc(Bytes frame) {
    const std::uint16_t crc = crc16_modbus(frame);
    frame.push_back(static_cast<std::uint8_t>(crc & 0xFF));
    frame.push_back(static_cast<std::uint8_t>(crc >> 8));
    return frame;
}

LineSettings line_9600_8n1() {
    return LineSettings{9600, 8, 'N', 1};
}

TEST(SimFrameSplitter, SplitsRequestsAnswersAndSkipsNoise) {
    const Bytes request = with_crc({0x03, 0x03, 0x00, 0x00, 0x00, 0x1D});
    const Bytes answer = with_crc({0x01, 0x03, 0x02, 0x18, 0x18});  // 7 bytes, not 8
    const Bytes write = with_crc({0x02, 0x10, 0x00, 0x01, 0x00, 0x01, 0x02, 0x12, 0x34});
    const Bytes exception = with_crc({0x02, 0x83, 0x02});
    Bytes stream = {0xFF, 0x00};  // noise before the first frame
    for (const Bytes* f : {&answer, &request, &write, &exception}) {
        stream.insert(stream.end(), f->begin(), f->end());
    }
    FrameSplitter splitter;
    // Byte by byte, as a paced bus delivers.
    std::vector<Bytes> frames;
    for (std::uint8_t b : stream) {
        splitter.push(&b, 1);
        while (auto f = splitter.next()) frames.push_back(*f);
    }
    // The noise is only skipped once it can start no frame; at the end the line is quiet.
    while (auto f = splitter.next(true)) frames.push_back(*f);
    EXPECT_EQ(frames, (std::vector<Bytes>{answer, request, write, exception}));
    EXPECT_TRUE(splitter.empty());
}

TEST(SimFrameSplitter, QuietLineDropsAPartialFrame) {
    FrameSplitter splitter;
    const Bytes partial = {0x01, 0x03, 0x00};
    splitter.push(partial.data(), partial.size());
    EXPECT_FALSE(splitter.next().has_value());
    EXPECT_FALSE(splitter.next(true).has_value());
    EXPECT_TRUE(splitter.empty());
}

TEST(SimVirtualBus, DeliversToEveryOtherPortAndNotBack) {
    auto bus = VirtualBus::create(3, {line_9600_8n1(), false});
    ASSERT_TRUE(bus.ok()) << bus.error().message;
    ASSERT_EQ((*bus)->port_count(), 3u);
    PortFd p0((*bus)->port_path(0));
    PortFd p1((*bus)->port_path(1));
    PortFd p2((*bus)->port_path(2));
    ASSERT_GE(p0.fd(), 0);
    ASSERT_GE(p1.fd(), 0);
    ASSERT_GE(p2.fd(), 0);

    const Bytes frame = {0x01, 0x03, 0x00, 0x00, 0x00, 0x02, 0xC4, 0x0B};
    p0.write(frame);
    EXPECT_EQ(p1.read(frame.size(), std::chrono::milliseconds(1000)), frame);
    EXPECT_EQ(p2.read(frame.size(), std::chrono::milliseconds(1000)), frame);
    // Neither an echo nor the hub's copy comes back to the writer.
    EXPECT_TRUE(p0.read(1, std::chrono::milliseconds(100)).empty());
}

TEST(SimVirtualBus, PacedDeliveryTakesTheCharacterTimes) {
    const LineSettings line = line_9600_8n1();
    auto bus = VirtualBus::create(2, {line, true});
    ASSERT_TRUE(bus.ok()) << bus.error().message;
    PortFd p0((*bus)->port_path(0));
    PortFd p1((*bus)->port_path(1));

    Bytes data(96);
    for (std::size_t i = 0; i < data.size(); ++i) data[i] = static_cast<std::uint8_t>(i);
    const auto start = Clock::now();
    p0.write(data);
    const Bytes got = p1.read(data.size(), std::chrono::milliseconds(3000));
    const auto took = Clock::now() - start;
    EXPECT_EQ(got, data);
    // Only a lower bound: a slow machine makes delivery later, never earlier.
    const auto expected = std::chrono::nanoseconds(line.char_time() * 96);  // 100 ms
    EXPECT_GE(took, expected * 8 / 10);
}

// What a UART at `receiver` makes of `bytes` sent back to back on `line`, as the hub sends
// one write; `errors` counts those received with an error.
Bytes uart_receives(const LineSettings& line, const LineSettings& receiver, const Bytes& bytes,
                    std::uint64_t& errors) {
    UartResampler uart(line, receiver);
    Nanos t = 0;
    for (const std::uint8_t b : bytes) {
        uart.send(t, b);
        t += line.char_time();
    }
    std::vector<Received> got;
    uart.take_until(t + kNanosPerSecond, got);
    Bytes out;
    errors = 0;
    for (const Received& r : got) {
        out.push_back(r.byte);
        if (r.parity_error || r.framing_error) ++errors;
    }
    return out;
}

// Sets a port's speed as a sniffer or a device does, on the slave it opened.
void set_speed(int fd, speed_t speed) {
    termios tio{};
    ASSERT_EQ(::tcgetattr(fd, &tio), 0);
    ::cfsetispeed(&tio, speed);
    ::cfsetospeed(&tio, speed);
    ASSERT_EQ(::tcsetattr(fd, TCSANOW, &tio), 0);
}

TEST(SimVirtualBus, PortAtAnotherBaudRateGetsWhatItsUartReceives) {
    const LineSettings line = line_9600_8n1();
    auto bus = VirtualBus::create(3, {line, true});
    ASSERT_TRUE(bus.ok()) << bus.error().message;
    PortFd p0((*bus)->port_path(0));
    PortFd p1((*bus)->port_path(1));
    PortFd p2((*bus)->port_path(2));
    set_speed(p1.fd(), B19200);

    const Bytes frame = with_crc({0x01, 0x03, 0x00, 0x00, 0x00, 0x02});
    std::uint64_t errors = 0;
    const Bytes garbage = uart_receives(line, {19200, 8, 'N', 1}, frame, errors);
    ASSERT_NE(garbage, frame);
    p0.write(frame);
    EXPECT_EQ(p1.read(garbage.size(), std::chrono::milliseconds(2000)), garbage);
    EXPECT_EQ(p2.read(frame.size(), std::chrono::milliseconds(2000)), frame);
    EXPECT_EQ((*bus)->receiver_errors(1), errors);
    EXPECT_EQ((*bus)->receiver_errors(2), 0u);

    // Back at the line's rate, the port gets the bytes as sent.
    set_speed(p1.fd(), B9600);
    p0.write(frame);
    EXPECT_EQ(p1.read(frame.size(), std::chrono::milliseconds(2000)), frame);
    EXPECT_EQ(p2.read(frame.size(), std::chrono::milliseconds(2000)), frame);
}

TEST(SimVirtualBus, PortAtACustomBaudRateGetsWhatItsUartReceives) {
    // A rate without a B* constant (BOTHER), as the sniffer sets one.
    const LineSettings line = line_9600_8n1();
    auto bus = VirtualBus::create(2, {line, true});
    ASSERT_TRUE(bus.ok()) << bus.error().message;
    PortFd p0((*bus)->port_path(0));
    PortFd p1((*bus)->port_path(1));
    ASSERT_TRUE(set_custom_baud(p1.fd(), 14400));

    const Bytes frame = with_crc({0x02, 0x04, 0x00, 0x10, 0x00, 0x01});
    std::uint64_t errors = 0;
    const Bytes garbage = uart_receives(line, {14400, 8, 'N', 1}, frame, errors);
    ASSERT_NE(garbage, frame);
    p0.write(frame);
    EXPECT_EQ(p1.read(garbage.size(), std::chrono::milliseconds(2000)), garbage);
}

TEST(SimVirtualBus, ReceiverWithParityOnANoParityLineGetsGarbage) {
    const LineSettings line = line_9600_8n1();
    auto bus = VirtualBus::create(3, {line, true});
    ASSERT_TRUE(bus.ok()) << bus.error().message;
    ASSERT_TRUE((*bus)->set_receiver_format(1, 8, 'E'));
    EXPECT_FALSE((*bus)->set_receiver_format(1, 9, 'E'));
    EXPECT_FALSE((*bus)->set_receiver_format(1, 8, 'X'));
    EXPECT_FALSE((*bus)->set_receiver_format(3, 8, 'E'));
    PortFd p0((*bus)->port_path(0));
    PortFd p1((*bus)->port_path(1));
    PortFd p2((*bus)->port_path(2));

    // Back to back, each character's parity sample is the stop bit and its stop sample the
    // next start bit: framing errors, then a receiver out of step.
    const Bytes frame = with_crc({0x01, 0x03, 0x00, 0x00, 0x00, 0x02});
    std::uint64_t errors = 0;
    const Bytes garbage = uart_receives(line, {9600, 8, 'E', 1}, frame, errors);
    ASSERT_NE(garbage, frame);
    ASSERT_GT(errors, 0u);
    p0.write(frame);
    EXPECT_EQ(p1.read(garbage.size(), std::chrono::milliseconds(2000)), garbage);
    EXPECT_EQ(p2.read(frame.size(), std::chrono::milliseconds(2000)), frame);
    EXPECT_EQ((*bus)->receiver_errors(1), errors);
}

TEST(SimVirtualBus, UnpacedBusGivesEveryPortTheBytesAsSent) {
    // Without times there is no waveform to sample.
    auto bus = VirtualBus::create(2, {line_9600_8n1(), false});
    ASSERT_TRUE(bus.ok()) << bus.error().message;
    ASSERT_TRUE((*bus)->set_receiver_format(1, 8, 'E'));
    PortFd p0((*bus)->port_path(0));
    PortFd p1((*bus)->port_path(1));
    set_speed(p1.fd(), B19200);
    const Bytes frame = with_crc({0x01, 0x03, 0x00, 0x00, 0x00, 0x02});
    p0.write(frame);
    EXPECT_EQ(p1.read(frame.size(), std::chrono::milliseconds(1000)), frame);
    EXPECT_EQ((*bus)->receiver_errors(1), 0u);
}

TEST(SimVirtualBus, UnplugHangsUpTheReader) {
    auto bus = VirtualBus::create(2, {line_9600_8n1(), false});
    ASSERT_TRUE(bus.ok()) << bus.error().message;
    PortFd p1((*bus)->port_path(1));
    ASSERT_GE(p1.fd(), 0);
    (*bus)->unplug(1);

    // Linux hangs up the slave side: poll reports POLLHUP, and read then gives end of file
    // (0; EIO is what a slave gets while the master side was never opened or is gone before
    // the open). Either way a reader learns at once that the adapter is gone.
    pollfd p{p1.fd(), POLLIN, 0};
    ASSERT_EQ(::poll(&p, 1, 1000), 1);
    EXPECT_NE(p.revents & (POLLHUP | POLLERR), 0) << "revents " << p.revents;
    std::uint8_t byte = 0;
    const ssize_t n = ::read(p1.fd(), &byte, 1);
    EXPECT_TRUE(n == 0 || (n == -1 && errno == EIO)) << "read " << n;
}

TEST(SimVirtualBus, RejectsNoPorts) {
    EXPECT_FALSE(VirtualBus::create(0, {}).ok());
}

TEST(SimDevice, RejectsUnknownProfileAndBadAddress) {
    auto bus = VirtualBus::create(1, {line_9600_8n1(), false});
    ASSERT_TRUE(bus.ok());
    const std::string& port = (*bus)->port_path(0);
    auto unknown = start_device("nosuch", 1, port, line_9600_8n1());
    ASSERT_FALSE(unknown.ok());
    EXPECT_NE(unknown.error().message.find("nosuch"), std::string::npos);
    EXPECT_FALSE(start_device("zb-uvi485", 16, port, line_9600_8n1()).ok());
    auto missing = start_device("pdu485", 1, "/dev/no-such-tty", line_9600_8n1());
    ASSERT_FALSE(missing.ok());
    EXPECT_NE(missing.error().message.find("/dev/no-such-tty"), std::string::npos);
}

const MasterEntry* find_entry(const std::vector<MasterEntry>& log, std::uint8_t slave,
                              std::uint8_t function, std::uint16_t address) {
    for (const MasterEntry& e : log) {
        if (e.slave == slave && e.function == function && e.address == address) return &e;
    }
    return nullptr;
}

bool contains(const Bytes& haystack, const Bytes& needle) {
    return std::search(haystack.begin(), haystack.end(), needle.begin(), needle.end()) !=
           haystack.end();
}

// Paced and unpaced: unpaced, a request and the answer before it can reach a device in one
// read, which the devices' frame splitting must handle.
class SimMasterOnBus : public ::testing::TestWithParam<bool> {};

TEST_P(SimMasterOnBus, PollsTheFourSeedDevices) {
    const LineSettings line = line_9600_8n1();
    auto bus = VirtualBus::create(6, {line, GetParam()});  // port 5: the sniffer's
    ASSERT_TRUE(bus.ok()) << bus.error().message;
    const auto& b = **bus;
    auto zb = start_device("zb-uvi485", 1, b.port_path(1), line);
    auto analyser = start_device("sensor-analyser", 2, b.port_path(2), line);
    auto pdu = start_device("pdu485", 3, b.port_path(3), line);
    auto relay = start_device("zyi-relay", 4, b.port_path(4), line);
    ASSERT_TRUE(zb.ok()) << zb.error().message;
    ASSERT_TRUE(analyser.ok()) << analyser.error().message;
    ASSERT_TRUE(pdu.ok()) << pdu.error().message;
    ASSERT_TRUE(relay.ok()) << relay.error().message;
    EXPECT_EQ((*relay)->holding(0x0003), 0);

    PortFd sniffer(b.port_path(5));
    Bytes heard;

    auto master = start_master(b.port_path(0), line, {}, 2, 0);
    ASSERT_TRUE(master.ok()) << master.error().message;
    const auto deadline = Clock::now() + std::chrono::seconds(10);
    while ((*master)->cycles() < 2 && Clock::now() < deadline) {
        const Bytes got = sniffer.read(4096, std::chrono::milliseconds(20));
        heard.insert(heard.end(), got.begin(), got.end());
    }
    const Bytes rest = sniffer.read(4096, std::chrono::milliseconds(50));
    heard.insert(heard.end(), rest.begin(), rest.end());
    ASSERT_EQ((*master)->cycles(), 2u);
    const std::vector<MasterEntry> log = (*master)->log();
    // Per cycle 5 reads; cycle 0 (every third) adds 3 writes.
    EXPECT_EQ(log.size(), 13u);

    // The transmitter answers one register to a read of two. libmodbus computes the length
    // the answer should have (9 bytes) from the request, gets a valid 7-byte frame and
    // rejects it (EMBBADDATA), so the read does not count as answered; the frames are on
    // the wire all the same.
    const MasterEntry* uv = find_entry(log, 1, 0x03, 0x0000);
    ASSERT_NE(uv, nullptr);
    EXPECT_FALSE(uv->answered);
    EXPECT_TRUE(uv->values.empty());
    const Bytes uv_request = {0x01, 0x03, 0x00, 0x00, 0x00, 0x02};
    const Bytes uv_answer = {0x01, 0x03, 0x02, 0x18, 0x18};
    EXPECT_TRUE(contains(heard, with_crc(uv_request)));
    EXPECT_TRUE(contains(heard, with_crc(uv_answer)));

    const MasterEntry* sensors = find_entry(log, 2, 0x03, 0x0000);
    ASSERT_NE(sensors, nullptr);
    EXPECT_TRUE(sensors->answered);
    ASSERT_EQ(sensors->values.size(), 10u);
    EXPECT_EQ(sensors->values[0], 2215);
    EXPECT_EQ(static_cast<std::int16_t>(sensors->values[4]), -125);
    EXPECT_EQ(sensors->values[1], 0);  // the undocumented odd register

    const MasterEntry* meter = find_entry(log, 3, 0x03, 0x0000);
    ASSERT_NE(meter, nullptr);
    EXPECT_TRUE(meter->answered);
    ASSERT_EQ(meter->values.size(), 29u);
    EXPECT_EQ(meter->values[0], 2205);  // 220.5 V

    const MasterEntry* relays = find_entry(log, 4, 0x03, 0x0003);
    ASSERT_NE(relays, nullptr);
    EXPECT_TRUE(relays->answered);
    EXPECT_EQ(relays->values.size(), 12u);

    // The writes of cycle 0, and what the devices hold afterwards.
    const MasterEntry* alarm = find_entry(log, 3, 0x06, 0x0009);
    ASSERT_NE(alarm, nullptr);
    EXPECT_TRUE(alarm->answered);
    EXPECT_EQ(alarm->values, std::vector<std::uint16_t>{2550});
    EXPECT_EQ((*pdu)->holding(0x0009), 2550);

    const MasterEntry* relay1 = find_entry(log, 4, 0x06, 0x0003);
    ASSERT_NE(relay1, nullptr);
    EXPECT_TRUE(relay1->answered);
    EXPECT_EQ((*relay)->holding(0x0003), 1);

    const MasterEntry* coefficient = find_entry(log, 1, 0x04, 0x0015);
    ASSERT_NE(coefficient, nullptr);
    EXPECT_TRUE(coefficient->answered);  // the echo
    EXPECT_EQ((*zb)->holding(0x0015), 18);

    // The second cycle read the relay after the write.
    ASSERT_EQ(log[12].slave, 4);
    ASSERT_EQ(log[12].values.size(), 12u);
    EXPECT_EQ(log[12].values[0], 1);
}

// The demo's master polls until stopped: a log of its requests would grow for as long as
// it runs (~1.5 KiB a second, unread).
TEST(SimMaster, RunUntilStoppedKeepsNoLog) {
    const LineSettings line = line_9600_8n1();
    auto bus = VirtualBus::create(2, {line, false});
    ASSERT_TRUE(bus.ok()) << bus.error().message;
    auto pdu = start_device("pdu485", 3, (*bus)->port_path(1), line);
    ASSERT_TRUE(pdu.ok()) << pdu.error().message;
    // Only the PDU meter answers; one cycle is enough to have logged its reads.
    Master::Devices devices;
    devices.zb_uvi485 = devices.sensor_analyser = devices.zyi_relay = devices.pdu485 = 3;
    auto master = start_master((*bus)->port_path(0), line, devices, 0, 0);
    ASSERT_TRUE(master.ok()) << master.error().message;
    const auto deadline = Clock::now() + std::chrono::seconds(10);
    while ((*master)->cycles() < 1 && Clock::now() < deadline) {
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    (*master)->stop();
    ASSERT_GE((*master)->cycles(), 1U);
    EXPECT_TRUE((*master)->log().empty());
}

// libmodbus sets B9600 for a rate without a B* constant; the simulated devices and master
// set such a rate themselves, or each port's receiver would take the line at 9600.
TEST(SimMaster, PollsAtABaudRateWithoutATermiosConstant) {
    const LineSettings line{14400, 8, 'N', 1};
    auto bus = VirtualBus::create(2, {line, true});
    ASSERT_TRUE(bus.ok()) << bus.error().message;
    auto pdu = start_device("pdu485", 3, (*bus)->port_path(1), line);
    ASSERT_TRUE(pdu.ok()) << pdu.error().message;
    Master::Devices devices;
    devices.zb_uvi485 = devices.sensor_analyser = devices.zyi_relay = devices.pdu485 = 3;
    auto master = start_master((*bus)->port_path(0), line, devices, 1, 0);
    ASSERT_TRUE(master.ok()) << master.error().message;
    const auto deadline = Clock::now() + std::chrono::seconds(10);
    while ((*master)->cycles() < 1 && Clock::now() < deadline) {
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    ASSERT_EQ((*master)->cycles(), 1U);
    const std::vector<MasterEntry> log = (*master)->log();
    const MasterEntry* read = find_entry(log, 3, 0x03, 0x0000);
    ASSERT_NE(read, nullptr);
    EXPECT_TRUE(read->answered);
    EXPECT_EQ((*bus)->receiver_errors(0), 0u);
    EXPECT_EQ((*bus)->receiver_errors(1), 0u);
}

INSTANTIATE_TEST_SUITE_P(Sim, SimMasterOnBus, ::testing::Values(true, false),
                         [](const ::testing::TestParamInfo<bool>& param) {
                             return param.param ? "paced" : "unpaced";
                         });

// The device quirks a standard master meets, sent as raw frames from a port of the bus.
class SimDeviceQuirks : public ::testing::Test {
  protected:
    void SetUp() override {
        auto bus = VirtualBus::create(2, {line_9600_8n1(), false});
        ASSERT_TRUE(bus.ok()) << bus.error().message;
        bus_ = std::move(*bus);
        port_ = std::make_unique<PortFd>(bus_->port_path(0));
    }

    Bytes ask(const Bytes& request, std::size_t want,
              std::chrono::milliseconds timeout = std::chrono::milliseconds(1000)) {
        port_->write(with_crc(request));
        return port_->read(want, timeout);
    }

    std::unique_ptr<VirtualBus> bus_;
    std::unique_ptr<PortFd> port_;
};

TEST_F(SimDeviceQuirks, ZbAnswersOneRegisterEchoesSettingsAndIgnoresErrors) {
    auto zb = start_device("zb-uvi485", 1, bus_->port_path(1), line_9600_8n1());
    ASSERT_TRUE(zb.ok()) << zb.error().message;
    // 6.1 of the manual: 01 03 02 18 18 + CRC.
    const Bytes uv = ask({0x01, 0x03, 0x00, 0x00, 0x00, 0x02}, 7);
    ASSERT_EQ(uv.size(), 7u);
    EXPECT_EQ(Bytes(uv.begin(), uv.begin() + 5), (Bytes{0x01, 0x03, 0x02, 0x18, 0x18}));
    // FC05 set address: echoed, stored, but the device keeps answering on 1.
    const Bytes set = {0x01, 0x05, 0x00, 0x20, 0x00, 0x02};
    const Bytes echo = ask(set, 8);
    ASSERT_EQ(echo.size(), 8u);
    EXPECT_EQ(Bytes(echo.begin(), echo.begin() + 6), set);
    EXPECT_EQ((*zb)->holding(0x0020), 2);
    // Unknown register, bad function, coefficient above 0xFF: silence.
    EXPECT_TRUE(
        ask({0x01, 0x03, 0x00, 0x01, 0x00, 0x01}, 1, std::chrono::milliseconds(200)).empty());
    EXPECT_TRUE(ask({0x01, 0x10, 0x00, 0x00, 0x00, 0x01, 0x02, 0x00, 0x01}, 1,
                    std::chrono::milliseconds(200))
                    .empty());
    EXPECT_TRUE(
        ask({0x01, 0x04, 0x00, 0x15, 0x01, 0x00}, 1, std::chrono::milliseconds(200)).empty());
    EXPECT_EQ((*zb)->holding(0x0015), 10);
}

TEST_F(SimDeviceQuirks, PduLimitsAndClearsTheEnergy) {
    auto pdu = start_device("pdu485", 7, bus_->port_path(1), line_9600_8n1());
    ASSERT_TRUE(pdu.ok()) << pdu.error().message;
    // More than 100 registers: Illegal Data Value.
    EXPECT_EQ(Bytes(ask({0x07, 0x03, 0x00, 0x00, 0x00, 101}, 5)).at(2), 0x03);
    // Outside the map: Illegal Data Address.
    const Bytes outside = ask({0x07, 0x03, 0x00, 0x1C, 0x00, 0x02}, 5);
    ASSERT_EQ(outside.size(), 5u);
    EXPECT_EQ(outside[1], 0x83);
    EXPECT_EQ(outside[2], 0x02);
    // An unsupported function: Illegal Function.
    EXPECT_EQ(Bytes(ask({0x07, 0x01, 0x00, 0x00, 0x00, 0x01}, 5)).at(2), 0x01);
    EXPECT_EQ((*pdu)->holding(0x0005), 12345);
    const Bytes clear = ask({0x07, 0x06, 0x00, 0x04, 0xAA, 0xBB}, 8);
    EXPECT_EQ(clear.size(), 8u);
    EXPECT_EQ((*pdu)->holding(0x0004), 0);
    EXPECT_EQ((*pdu)->holding(0x0005), 0);
}

TEST_F(SimDeviceQuirks, RelaySwitchesAllAndAnswersLate) {
    auto relay = start_device("zyi-relay", 5, bus_->port_path(1), line_9600_8n1());
    ASSERT_TRUE(relay.ok()) << relay.error().message;
    const auto start = Clock::now();
    EXPECT_EQ(ask({0x05, 0x06, 0x00, 0x02, 0x00, 0x01}, 8).size(), 8u);
    EXPECT_GE(Clock::now() - start, std::chrono::milliseconds(100));
    for (std::uint16_t r = 0x0003; r <= 0x000E; ++r) EXPECT_EQ((*relay)->holding(r), 1) << r;
    EXPECT_EQ(ask({0x05, 0x06, 0x00, 0x01, 0x00, 0x00}, 8).size(), 8u);
    for (std::uint16_t r = 0x0003; r <= 0x000E; ++r) EXPECT_EQ((*relay)->holding(r), 0) << r;
    // A relay value other than 0/1: Illegal Data Value.
    const Bytes bad = ask({0x05, 0x06, 0x00, 0x03, 0x00, 0x02}, 5);
    ASSERT_EQ(bad.size(), 5u);
    EXPECT_EQ(bad[1], 0x86);
    EXPECT_EQ(bad[2], 0x03);
}

}  // namespace
}  // namespace rtuscope::sim
