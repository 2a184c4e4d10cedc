// The four seed devices, simulated on libmodbus's RTU server side: modbus_reply on a
// register mapping where a device behaves as the standard says, raw answers (with their CRC)
// where its manual shows it does not.
#include <fcntl.h>
#include <modbus/modbus.h>
#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <chrono>
#include <system_error>

#include "sim/sim.hpp"
#include "sim/sim_util.hpp"

namespace rtuscope::sim {

namespace {

using Clock = std::chrono::steady_clock;

enum class Kind { zb_uvi485, sensor_analyser, pdu485, zyi_relay };

struct ProfileInfo {
    const char* name;
    Kind kind;
    int min_address;
    int max_address;
    int registers;  // size of the holding mapping
};

// Address ranges as profiles/*.toml give them.
constexpr ProfileInfo kProfiles[] = {
    {"zb-uvi485", Kind::zb_uvi485, 0, 15, 0x21},  // 0x0000, EEPROM cells 0x0015 and 0x0020
    {"sensor-analyser", Kind::sensor_analyser, 1, 247, 18 * 100},
    {"pdu485", Kind::pdu485, 1, 250, 0x1D},
    {"zyi-relay", Kind::zyi_relay, 1, 245, 0x0F},
};

constexpr int kPduMaxRegisters = 100;  // 5.2 注: at most 100 registers per request

std::uint16_t be16(const std::vector<std::uint8_t>& b, std::size_t at) {
    return static_cast<std::uint16_t>((b[at] << 8) | b[at + 1]);
}

std::uint16_t u16(int value) {
    return static_cast<std::uint16_t>(value);
}

class SimDevice final : public Device {
  public:
    SimDevice(const ProfileInfo& info, std::uint8_t address, LineSettings line, modbus_t* ctx,
              modbus_mapping_t* map)
        : info_(info), address_(address), line_(line), ctx_(ctx), map_(map), rng_(address) {
        fill();
    }

    ~SimDevice() override {
        stop_ = true;
        if (thread_.joinable()) thread_.join();
        modbus_close(ctx_);
        modbus_free(ctx_);
        modbus_mapping_free(map_);
    }

    SimDevice(const SimDevice&) = delete;
    SimDevice& operator=(const SimDevice&) = delete;

    [[nodiscard]] std::uint16_t holding(std::uint16_t address) const override {
        std::lock_guard lock(mutex_);
        return address < map_->nb_registers ? map_->tab_registers[address] : 0;
    }

    Status start() {
        try {
            thread_ = std::thread([this] { run(); });
        } catch (const std::system_error& e) {
            return Error{std::string("cannot start the device thread: ") + e.what()};
        }
        return ok_status();
    }

  private:
    void fill();
    void run();
    void handle(const std::vector<std::uint8_t>& req);
    void handle_zb(const std::vector<std::uint8_t>& req);
    void handle_pdu(const std::vector<std::uint8_t>& req);
    void handle_relay(const std::vector<std::uint8_t>& req);
    void reply(const std::vector<std::uint8_t>& req) {
        std::lock_guard lock(mutex_);
        modbus_reply(ctx_, req.data(), static_cast<int>(req.size()), map_);
    }
    void exception(const std::vector<std::uint8_t>& req, unsigned code) {
        modbus_reply_exception(ctx_, req.data(), code);
    }
    void send_raw(const std::vector<std::uint8_t>& bytes) {
        write_all(modbus_get_socket(ctx_), bytes);
    }
    // Sleeps, but returns early when the device is being destroyed.
    void pause(std::chrono::milliseconds ms) {
        const auto until = Clock::now() + ms;
        while (!stop_ && Clock::now() < until) {
            std::this_thread::sleep_for(
                std::min<Clock::duration>(until - Clock::now(), std::chrono::milliseconds(10)));
        }
    }

    std::uint16_t& reg(std::size_t address) { return map_->tab_registers[address]; }

    const ProfileInfo& info_;
    const std::uint8_t address_;
    const LineSettings line_;
    modbus_t* const ctx_;
    modbus_mapping_t* const map_;
    mutable std::mutex mutex_;  // the mapping: the device thread writes, holding() reads
    std::atomic<bool> stop_{false};
    std::thread thread_;
    std::uint32_t rng_;  // the relay's answer delay: varying, but the same on every run
};

void SimDevice::fill() {
    switch (info_.kind) {
        case Kind::zb_uvi485:
            reg(0x0000) = 0x1818;  // 616.8 µW/cm², the manual's example answer
            reg(0x0015) = 0x000A;  // correction coefficient 1.0, the default
            reg(0x0020) = address_;
            break;
        case Kind::sensor_analyser: {
            // ch1 s1-s5, ch2 s1, ch12 s16: a mains voltage (the manual's 0x08A7), a current,
            // a negative temperature, a humidity, a pressure; the odd registers stay 0.
            const int ch1[] = {2215, 52, -125, 634, 1013};
            for (int s = 0; s < 5; ++s) reg(static_cast<std::size_t>(s) * 2) = u16(ch1[s]);
            reg(0x0064) = u16(238);
            reg(0x046A) = u16(-40);
            break;
        }
        case Kind::pdu485: {
            const int values[] = {
                2205,   // 0x0000 voltage 220.5 V
                523,    // 0x0001 current 5.23 A
                1090,   // 0x0002 power 1090 W
                945,    // 0x0003 power factor 0.945
                0,      // 0x0004 energy high word
                12345,  // 0x0005 energy low word: 12345 kWh
                address_,
                3,     // 0x0007 9600 baud
                160,   // 0x0008 current high alarm 16.0 A
                2500,  // 0x0009 voltage high alarm 250.0 V
                1900,  // 0x000A voltage low alarm 190.0 V
                0xFF,  // 0x000B cycling display
                0,     // 0x000C current low alarm
                450,   // 0x000D temperature high alarm 45.0 °C
                -100,  // 0x000E temperature low alarm -10.0 °C
                900,   // 0x000F humidity high alarm 90.0 %
                100,   // 0x0010 humidity low alarm 10.0 %
                235,      456, 241, 441, -52, 612, 0, 0, 0, 0, 0, 0,  // sensors 1-3; 4-6 absent
            };
            for (std::size_t a = 0; a < std::size(values); ++a) reg(a) = u16(values[a]);
            break;
        }
        case Kind::zyi_relay:
            reg(0x0000) = address_;
            reg(0x0005) = 1;  // channels 3 and 7 on
            reg(0x0009) = 1;
            break;
    }
}

void SimDevice::run() {
    const int fd = modbus_get_socket(ctx_);
    FrameSplitter splitter;
    // Quiet this long and a partial frame is abandoned; generous (many t3.5) because the
    // device thread itself may be late to look, e.g. while the relay waits to answer.
    const auto silence = std::max<Clock::duration>(std::chrono::milliseconds(50),
                                                   std::chrono::nanoseconds(line_.t35() * 10));
    auto last_byte = Clock::now();
    while (!stop_) {
        pollfd p{fd, POLLIN, 0};
        const int n = ::poll(&p, 1, 20);
        if (n < 0 && errno != EINTR) return;
        if (n > 0) {
            if (p.revents & POLLIN) {
                std::uint8_t buf[512];
                const ssize_t got = ::read(fd, buf, sizeof buf);
                if (got < 0 && errno != EAGAIN && errno != EINTR) return;  // unplugged (EIO)
                if (got > 0) {
                    splitter.push(buf, static_cast<std::size_t>(got));
                    last_byte = Clock::now();
                }
            } else if (p.revents & (POLLHUP | POLLERR | POLLNVAL)) {
                return;  // the bus port is gone: nothing will ever come again
            }
        }
        const bool quiet = !splitter.empty() && Clock::now() - last_byte >= silence;
        while (auto frame = splitter.next(quiet)) {
            if (stop_) return;
            // A real slave knows a request has ended only after t3.5 of silence, so it
            // never answers sooner; the sniffer would rightly flag an answer that did.
            const auto turnaround =
                std::chrono::nanoseconds(line_.t35()) + std::chrono::milliseconds(2);
            while (!stop_ && Clock::now() < last_byte + turnaround) {
                std::this_thread::sleep_for(std::chrono::microseconds(200));
            }
            handle(*frame);
        }
    }
}

void SimDevice::handle(const std::vector<std::uint8_t>& req) {
    // Only requests to this address; every other frame is someone else's conversation. None
    // of the seed devices acts on the Modbus broadcast address 0 (pdu485's manual: "本机无此
    // 功能"; zb-uvi485 uses 0 as an ordinary address and 0xFF as its broadcast, not simulated).
    if (req.size() < 4 || req[0] != address_) return;
    const std::uint8_t fc = req[1];
    // The lengths the standard gives a request; anything else is an answer that happened to
    // carry this address (a misframe) and is not answered.
    if ((fc >= 1 && fc <= 6 && req.size() != 8) ||
        ((fc == 15 || fc == 16) && (req.size() < 9 || req.size() != 9u + req[6]))) {
        return;
    }
    switch (info_.kind) {
        case Kind::zb_uvi485:
            handle_zb(req);
            return;
        case Kind::pdu485:
            handle_pdu(req);
            return;
        case Kind::zyi_relay:
            handle_relay(req);
            return;
        case Kind::sensor_analyser:
            if (fc != MODBUS_FC_READ_HOLDING_REGISTERS) {
                exception(req, MODBUS_EXCEPTION_ILLEGAL_FUNCTION);
            } else {
                reply(req);
            }
            return;
    }
}

// zb-uvi485: every error (unknown register, function or value) gets no answer at all
// (Appendix A 说明 and 6.2/6.3 "若设置不成功时，不应答").
void SimDevice::handle_zb(const std::vector<std::uint8_t>& req) {
    const std::uint16_t address = be16(req, 2);
    const std::uint16_t value = be16(req, 4);
    switch (req[1]) {
        case 0x03: {
            if (address != 0x0000 || value < 1 || value > MODBUS_MAX_READ_REGISTERS) return;
            // 6.1: one register (byte count 2) whatever the quantity asked.
            std::uint16_t uv = 0;
            {
                std::lock_guard lock(mutex_);
                uv = reg(0x0000);
            }
            send_raw(with_crc({address_, 0x03, 0x02, static_cast<std::uint8_t>(uv >> 8),
                               static_cast<std::uint8_t>(uv & 0xFF)}));
            return;
        }
        case 0x04:
            // 6.2: set the correction coefficient; only the low byte is used and the high byte
            // is reserved, so a value above 0xFF is a failed setting.
            if (address != 0x0015 || value > 0xFF) return;
            break;
        case 0x05:
            // 6.3: set the slave address (0-15). The new address is stored in the EEPROM
            // cell but the simulated device keeps answering on its old one: a master that
            // changed it would have to restart the device, which keeps the simulator simple.
            if (address != 0x0020 || value > 15) return;
            break;
        default:
            return;
    }
    {
        std::lock_guard lock(mutex_);
        reg(address) = value;
    }
    send_raw(req);  // the request repeated byte for byte, CRC included
}

void SimDevice::handle_pdu(const std::vector<std::uint8_t>& req) {
    const std::uint8_t fc = req[1];
    if (fc != MODBUS_FC_READ_HOLDING_REGISTERS && fc != MODBUS_FC_WRITE_SINGLE_REGISTER &&
        fc != MODBUS_FC_WRITE_MULTIPLE_REGISTERS) {
        exception(req, MODBUS_EXCEPTION_ILLEGAL_FUNCTION);
        return;
    }
    // The meter's own limit is below libmodbus's 125/123; above it, Illegal Data Value as
    // the Modbus standard has it (the manual swaps the names of 02 and 03, not the rule).
    if (fc != MODBUS_FC_WRITE_SINGLE_REGISTER && be16(req, 4) > kPduMaxRegisters) {
        exception(req, MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE);
        return;
    }
    // Addresses outside the map get exception 02 from modbus_reply. (The manual's section 2
    // says registers after the end of a data area get no answer at all; the standard answer
    // is simulated instead.)
    std::lock_guard lock(mutex_);
    modbus_reply(ctx_, req.data(), static_cast<int>(req.size()), map_);
    // 7.1: writing 0xAABB to the energy (either half) clears it.
    if (reg(0x0004) == 0xAABB || reg(0x0005) == 0xAABB) {
        reg(0x0004) = 0;
        reg(0x0005) = 0;
    }
}

void SimDevice::handle_relay(const std::vector<std::uint8_t>& req) {
    // "1 协议概述 注": answers come 0.1-0.5 s, typically 0.2 s, after the request.
    rng_ = rng_ * 1103515245u + 12345u;
    pause(std::chrono::milliseconds(150 + (rng_ >> 16) % 101));
    if (stop_) return;
    const std::uint8_t fc = req[1];
    if (fc == MODBUS_FC_READ_HOLDING_REGISTERS) {
        reply(req);
        return;
    }
    if (fc != MODBUS_FC_WRITE_SINGLE_REGISTER) {
        exception(req, MODBUS_EXCEPTION_ILLEGAL_FUNCTION);
        return;
    }
    const std::uint16_t address = be16(req, 2);
    const std::uint16_t value = be16(req, 4);
    const bool bad_value = (address == 0x0000 && (value < 3 || value > 245)) ||
                           (address >= 0x0001 && address <= 0x000E && value > 1);
    if (bad_value) {
        exception(req, MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE);
        return;
    }
    std::lock_guard lock(mutex_);
    modbus_reply(ctx_, req.data(), static_cast<int>(req.size()), map_);
    // 0x0001 = 0 switches every channel off, 0x0002 = 1 every channel on; the other value
    // of each is not documented and does nothing here. A write to 0x0000 (the address) is
    // stored but, as with zb-uvi485, the device keeps its address.
    if ((address == 0x0001 && value == 0) || (address == 0x0002 && value == 1)) {
        for (std::size_t r = 0x0003; r <= 0x000E; ++r) reg(r) = address == 0x0002 ? 1 : 0;
    }
}

}  // namespace

Result<std::unique_ptr<Device>> start_device(const std::string& profile, std::uint8_t address,
                                             const std::string& port, LineSettings line) {
    const ProfileInfo* info = nullptr;
    for (const ProfileInfo& p : kProfiles) {
        if (profile == p.name) info = &p;
    }
    if (info == nullptr) return Error{"no simulated device for profile \"" + profile + "\""};
    if (address < info->min_address || address > info->max_address) {
        return Error{profile + ": address " + std::to_string(address) + " is outside " +
                     std::to_string(info->min_address) + "-" + std::to_string(info->max_address)};
    }
    modbus_t* ctx = modbus_new_rtu(port.c_str(), static_cast<int>(line.baud), line.parity,
                                   line.data_bits, line.stop_bits);
    if (ctx == nullptr) return Error{errno_message("cannot create a Modbus RTU context")};
    // libmodbus only accepts 0-247 here; the device filters addresses itself, so a higher
    // one (pdu485 allows 250) is fine without it.
    if (address <= 247) modbus_set_slave(ctx, address);
    if (modbus_connect(ctx) != 0) {
        Error error{port + ": cannot open: " + modbus_strerror(errno)};
        modbus_free(ctx);
        return error;
    }
    const int fd = modbus_get_socket(ctx);
    set_line_speed(fd, line.baud);
    ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) | O_NONBLOCK);
    modbus_mapping_t* map = modbus_mapping_new(0, 0, info->registers, 0);
    if (map == nullptr) {
        modbus_close(ctx);
        modbus_free(ctx);
        return Error{errno_message("cannot allocate the register map")};
    }
    auto device = std::make_unique<SimDevice>(*info, address, line, ctx, map);
    if (auto st = device->start(); !st) return st.error();
    return std::unique_ptr<Device>(std::move(device));
}

Result<std::vector<std::unique_ptr<Device>>> start_seed_devices(const VirtualBus& bus,
                                                                LineSettings line) {
    const std::array<const char*, 4> kinds = {"zb-uvi485", "sensor-analyser", "pdu485",
                                              "zyi-relay"};
    std::vector<std::unique_ptr<Device>> devices;
    for (std::size_t i = 0; i < kinds.size(); ++i) {
        auto device =
            start_device(kinds[i], static_cast<std::uint8_t>(i + 1), bus.port_path(i + 1), line);
        if (!device) return device.error();
        devices.push_back(std::move(*device));
    }
    return devices;
}

}  // namespace rtuscope::sim
