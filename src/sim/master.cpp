// The simulated master: libmodbus's RTU client polling the four seed devices in cycles,
// with the writes a plant would do now and then, and a log of what it asked and got.
#include <modbus/modbus.h>
#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <system_error>

#include "sim/sim.hpp"
#include "sim/sim_util.hpp"

namespace rtuscope::sim {

namespace {

using Clock = std::chrono::steady_clock;

constexpr std::uint16_t u16v(int value) {
    return static_cast<std::uint16_t>(value);
}

struct Request {
    enum class Kind { read, write, zb_set };  // zb_set: zb-uvi485's non-standard FC04
    Kind kind;
    std::uint8_t slave;
    std::uint16_t address;
    std::uint16_t value;  // quantity to read, or value to write
};

class SimMaster final : public Master {
  public:
    SimMaster(modbus_t* ctx, Devices devices, std::size_t max_cycles, int pause_ms)
        : ctx_(ctx), devices_(devices), max_cycles_(max_cycles), pause_ms_(pause_ms) {}

    ~SimMaster() override {
        stop();
        if (thread_.joinable()) thread_.join();
        modbus_close(ctx_);
        modbus_free(ctx_);
    }

    SimMaster(const SimMaster&) = delete;
    SimMaster& operator=(const SimMaster&) = delete;

    void stop() override {
        {
            std::lock_guard lock(mutex_);
            stop_ = true;
        }
        wake_.notify_all();
    }

    [[nodiscard]] std::vector<MasterEntry> log() const override {
        std::lock_guard lock(mutex_);
        return log_;
    }

    [[nodiscard]] std::size_t cycles() const override { return cycles_; }

    Status start() {
        try {
            thread_ = std::thread([this] { run(); });
        } catch (const std::system_error& e) {
            return Error{std::string("cannot start the master thread: ") + e.what()};
        }
        return ok_status();
    }

  private:
    [[nodiscard]] bool stopping() const {
        std::lock_guard lock(mutex_);
        return stop_;
    }
    std::vector<Request> plan(std::size_t cycle) const;
    void run();
    MasterEntry execute(const Request& r);
    bool zb_set(const Request& r);

    modbus_t* const ctx_;
    const Devices devices_;
    const std::size_t max_cycles_;
    const int pause_ms_;
    mutable std::mutex mutex_;  // log_ and stop_
    std::condition_variable wake_;
    bool stop_ = false;
    std::vector<MasterEntry> log_;
    std::atomic<std::size_t> cycles_{0};
    std::thread thread_;
};

std::vector<Request> SimMaster::plan(std::size_t cycle) const {
    using K = Request::Kind;
    std::vector<Request> requests = {
        // Two registers as the manual's example asks; the transmitter answers one.
        {K::read, devices_.zb_uvi485, 0x0000, 2},
        {K::read, devices_.sensor_analyser, 0x0000, 10},  // ch1 sensors 1-5
        {K::read, devices_.sensor_analyser, 0x0064, 1},   // ch2 sensor 1
        {K::read, devices_.pdu485, 0x0000, 29},
        {K::read, devices_.zyi_relay, 0x0003, 12},
    };
    if (cycle % 3 == 0) {
        const std::size_t k = cycle / 3;
        // The voltage alarm between 255.0 V and 250.0 V.
        requests.push_back({K::write, devices_.pdu485, 0x0009, u16v(k % 2 == 0 ? 2550 : 2500)});
        // One channel on, the same channel off, all on, all off; then the next channel.
        const auto channel = static_cast<std::uint16_t>(0x0003 + (k / 4) % 12);
        switch (k % 4) {
            case 0:
                requests.push_back({K::write, devices_.zyi_relay, channel, 1});
                break;
            case 1:
                requests.push_back({K::write, devices_.zyi_relay, channel, 0});
                break;
            case 2:
                requests.push_back({K::write, devices_.zyi_relay, 0x0002, 1});
                break;
            default:
                requests.push_back({K::write, devices_.zyi_relay, 0x0001, 0});
                break;
        }
        // The coefficient of the manual's example (1.8), then back to the default 1.0.
        requests.push_back({K::zb_set, devices_.zb_uvi485, 0x0015, u16v(k % 2 == 0 ? 18 : 10)});
    }
    return requests;
}

void SimMaster::run() {
    for (std::size_t cycle = 0; max_cycles_ == 0 || cycle < max_cycles_; ++cycle) {
        for (const Request& r : plan(cycle)) {
            if (stopping()) return;
            MasterEntry entry = execute(r);
            if (max_cycles_ != 0) {
                std::lock_guard lock(mutex_);
                log_.push_back(std::move(entry));
            }
            if (pause_ms_ > 0) {
                std::unique_lock lock(mutex_);
                wake_.wait_for(lock, std::chrono::milliseconds(pause_ms_), [&] { return stop_; });
            }
        }
        ++cycles_;
    }
}

MasterEntry SimMaster::execute(const Request& r) {
    MasterEntry entry;
    entry.slave = r.slave;
    entry.address = r.address;
    // Whatever a failed exchange left behind (a late answer) must not be read as the next
    // answer.
    modbus_flush(ctx_);
    modbus_set_slave(ctx_, r.slave);
    switch (r.kind) {
        case Request::Kind::read: {
            entry.function = MODBUS_FC_READ_HOLDING_REGISTERS;
            std::vector<std::uint16_t> values(r.value);
            const int n = modbus_read_registers(ctx_, r.address, r.value, values.data());
            if (n > 0) {
                values.resize(static_cast<std::size_t>(n));
                entry.values = std::move(values);
            }
            entry.answered = n == r.value;
            break;
        }
        case Request::Kind::write:
            entry.function = MODBUS_FC_WRITE_SINGLE_REGISTER;
            entry.values = {r.value};
            entry.answered = modbus_write_register(ctx_, r.address, r.value) == 1;
            break;
        case Request::Kind::zb_set:
            entry.function = 0x04;
            entry.values = {r.value};
            entry.answered = zb_set(r);
            break;
    }
    return entry;
}

// zb-uvi485's FC04 "set correction coefficient": libmodbus adds the CRC to the raw request,
// but modbus_receive_confirmation cannot take the answer: it parses an FC04 answer as Read
// Input Registers, takes the 0x00 of the echoed address as the byte count, reads 5 of the 8
// bytes, fails the CRC and leaves 3 bytes behind. The echo is read here instead.
bool SimMaster::zb_set(const Request& r) {
    const std::vector<std::uint8_t> raw = {
        r.slave,
        0x04,
        static_cast<std::uint8_t>(r.address >> 8),
        static_cast<std::uint8_t>(r.address & 0xFF),
        static_cast<std::uint8_t>(r.value >> 8),
        static_cast<std::uint8_t>(r.value & 0xFF),
    };
    if (modbus_send_raw_request(ctx_, raw.data(), static_cast<int>(raw.size())) < 0) return false;
    const std::vector<std::uint8_t> expected = with_crc(raw);
    std::vector<std::uint8_t> got;
    const int fd = modbus_get_socket(ctx_);
    const auto deadline = Clock::now() + std::chrono::seconds(1);  // the response timeout
    while (got.size() < expected.size()) {
        const auto left =
            std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
        if (left.count() <= 0) break;
        pollfd p{fd, POLLIN, 0};
        const int n = ::poll(&p, 1, static_cast<int>(left.count()) + 1);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0 || !(p.revents & POLLIN)) break;
        std::uint8_t buf[64];
        const ssize_t k = ::read(fd, buf, sizeof buf);
        if (k < 0 && (errno == EAGAIN || errno == EINTR)) continue;
        if (k <= 0) break;
        got.insert(got.end(), buf, buf + k);
    }
    return got == expected;
}

}  // namespace

Result<std::unique_ptr<Master>> start_master(const std::string& port, LineSettings line,
                                             Master::Devices devices, std::size_t max_cycles,
                                             int pause_ms) {
    for (const std::uint8_t a :
         {devices.zb_uvi485, devices.sensor_analyser, devices.pdu485, devices.zyi_relay}) {
        // libmodbus's client only addresses 1-247 (and 0, the broadcast, gets no answer).
        if (a < 1 || a > 247) {
            return Error{"the simulated master cannot poll address " + std::to_string(a) +
                         " (libmodbus addresses 1-247)"};
        }
    }
    if (pause_ms < 0) return Error{"the master's pause must not be negative"};
    modbus_t* ctx = modbus_new_rtu(port.c_str(), static_cast<int>(line.baud), line.parity,
                                   line.data_bits, line.stop_bits);
    if (ctx == nullptr) return Error{errno_message("cannot create a Modbus RTU context")};
    if (modbus_connect(ctx) != 0) {
        Error error{port + ": cannot open: " + modbus_strerror(errno)};
        modbus_free(ctx);
        return error;
    }
    set_line_speed(modbus_get_socket(ctx), line.baud);
    // zyi-relay answers up to 0.5 s late; a second leaves room for the transmission.
    modbus_set_response_timeout(ctx, 1, 0);
    auto master = std::make_unique<SimMaster>(ctx, devices, max_cycles, pause_ms);
    if (auto st = master->start(); !st) return st.error();
    return std::unique_ptr<Master>(std::move(master));
}

}  // namespace rtuscope::sim
