// A virtual RS-485 bus for tests and `rtuscope demo`: pseudo-terminals joined by a hub,
// the four seed devices simulated on libmodbus's RTU slave API, and a polling master on
// libmodbus. Nothing here is used when rtuscope sniffs a real line; the sniffer opens a
// port of this bus exactly as it opens /dev/ttyUSB0.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "framing/line_settings.hpp"
#include "util/result.hpp"

namespace rtuscope::sim {

// N ports, each a pseudo-terminal. Every byte written to one port is delivered to every
// other port (not back to the writer: the simulated transceivers do not echo). Paced,
// the hub releases bytes at the line's character time, so gaps between frames and
// turnaround times are real; unpaced, bytes pass as fast as the kernel moves them.
//
// Paced, each port also has a receiver of its own, as each adapter on a real line has its
// own UART: so that a detector trying one setting after another can be tested through the
// real tty code. Its baud rate and stop bits are what whoever opened the port set on it
// (read from the pty whenever someone writes, and every few milliseconds); its data bits
// and parity are set_receiver_format's, since a Linux pty forces 8 data bits without
// parity. While they match the line's baud rate and format (stop bits aside: a UART checks
// only the first), or cannot be read, the port gets the bytes as sent. Otherwise it gets
// what a 16550-style UART at its settings makes of the line's waveform (uart_model.hpp),
// each byte when that UART completes it: garbage, break bytes, fewer or more bytes than
// sent. A pty carries no error marks, so bytes received with parity or framing errors come
// as received, as from an adapter whose driver reports no errors; receiver_errors counts
// them. Unpaced, bytes have no times to sample, and every port gets them as sent.
class VirtualBus {
  public:
    struct Options {
        LineSettings line;
        bool paced = true;
    };

    static Result<std::unique_ptr<VirtualBus>> create(std::size_t ports, Options options);
    ~VirtualBus();  // stops the hub and closes every port
    VirtualBus(const VirtualBus&) = delete;
    VirtualBus& operator=(const VirtualBus&) = delete;

    // The path a device, the master or the sniffer opens ("/dev/pts/7"); empty for a port
    // number the bus does not have.
    [[nodiscard]] const std::string& port_path(std::size_t port) const;
    [[nodiscard]] std::size_t port_count() const;
    // Closes one port's pseudo-terminal pair under whoever has it open (tests: the
    // adapter unplugged). Its reader then gets a hang-up (POLLHUP; read gives 0 or EIO).
    // Traffic nobody reads (a sniffer's port before it starts) is dropped beyond about a
    // second's worth, so a late reader does not get a flood of old frames.
    void unplug(std::size_t port);
    // The data bits (5-8) and parity ('N', 'E', 'O') of a port's receiver; by default the
    // line's. False, and nothing changes, for a port the bus does not have or a format
    // that does not exist.
    bool set_receiver_format(std::size_t port, std::uint8_t data_bits, char parity);
    // Characters the port's receiver got with a parity or framing error (a break too).
    [[nodiscard]] std::uint64_t receiver_errors(std::size_t port) const;

    struct Impl;

  private:
    explicit VirtualBus(std::unique_ptr<Impl> impl);
    std::unique_ptr<Impl> impl_;
};

// One simulated seed device on a port, answering in a thread until destroyed.
//   "zb-uvi485":       FC03 0x0000 = UV intensity (raw/10 µW/cm²), answers ONE register
//                      even when two are asked (as the manual shows); FC04 (set correction
//                      coefficient, EEPROM 0x0015) and FC05 (set address, EEPROM 0x0020)
//                      answered by an echo; errors get no answer at all. The new
//                      address is stored, but the device keeps answering on its own.
//                      holding() also shows the EEPROM cells 0x0015 and 0x0020.
//   "sensor-analyser": FC03 at (channel-1)*100 + (sensor-1)*2, signed 16-bit x10 values,
//                      0 in the unused odd registers; 0..1799 (18 channels), other
//                      functions 01, other addresses 02.
//   "pdu485":          FC03/06/10 on the 29-register map of profiles/pdu485.toml,
//                      at most 100 registers per request (else 03), addresses outside the
//                      map 02, other functions 01; writing 0xAABB to 0x0004 (or 0x0005)
//                      clears the energy.
//   "zyi-relay":       FC03/06, 0x0000 address, 0x0001 all off, 0x0002 all on, 0x0003...
//                      12 relay registers (values 0/1, else exception 03); answers 150-250
//                      ms after the request (the manual: 0.1-0.5 s, typically 0.2 s).
// Every device reads the whole bus and answers only frames with its own address. Values are
// fixed, plausible readings (e.g. UV 616.8, PDU 220.5 V, a negative analyser value).
class Device {
  public:
    virtual ~Device() = default;
    // The registers the device holds now (holding table), for tests to compare with what
    // the sniffer decoded.
    [[nodiscard]] virtual std::uint16_t holding(std::uint16_t address) const = 0;
};

// Errors: a profile that is not one of the four, an address outside the profile's range,
// a port libmodbus cannot open.
Result<std::unique_ptr<Device>> start_device(const std::string& profile, std::uint8_t address,
                                             const std::string& port, LineSettings line);

// The four seed devices at addresses 1-4 (zb-uvi485, sensor-analyser, pdu485, zyi-relay),
// each on the bus's port of its address: the demo's bus. Errors as start_device's.
Result<std::vector<std::unique_ptr<Device>>> start_seed_devices(const VirtualBus& bus,
                                                                LineSettings line);

// What the master did, one entry per request, for tests to compare with the sniffer.
struct MasterEntry {
    std::uint8_t slave = 0;
    std::uint8_t function = 0;
    std::uint16_t address = 0;
    std::vector<std::uint16_t> values;  // read back, or written
    bool answered = false;              // libmodbus got a valid answer
};

// A libmodbus master polling the four seed devices (at the addresses given, 1-247: what
// libmodbus can address) in cycles: reads of each device's registers and, every third
// cycle from the first, writes (PDU alarm threshold, relay on/off/all on/all off, ZB
// correction coefficient with the raw non-standard FC04). Its read of two ZB registers is
// logged as not answered: libmodbus rejects the one-register answer.
class Master {
  public:
    struct Devices {
        std::uint8_t zb_uvi485 = 1;
        std::uint8_t sensor_analyser = 2;
        std::uint8_t pdu485 = 3;
        std::uint8_t zyi_relay = 4;
    };
    virtual ~Master() = default;
    // Stops after the current request.
    virtual void stop() = 0;
    // Every request so far (a copy, safe while the master runs) of a master started for a
    // number of cycles. One run until stopped (the demo's) keeps none: it would grow for
    // as long as the demo runs, and nothing reads it.
    [[nodiscard]] virtual std::vector<MasterEntry> log() const = 0;
    // Cycles completed so far.
    [[nodiscard]] virtual std::size_t cycles() const = 0;
};

// `max_cycles` 0: until stopped. `pause_ms` between requests.
Result<std::unique_ptr<Master>> start_master(const std::string& port, LineSettings line,
                                             Master::Devices devices, std::size_t max_cycles,
                                             int pause_ms);

}  // namespace rtuscope::sim
