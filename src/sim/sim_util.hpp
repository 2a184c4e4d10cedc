// Private helpers of the simulator: error text from errno, CRC-terminated frames, a
// pseudo-terminal's speed, and the splitter the simulated devices use to find frames in
// what they hear on the shared bus.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace rtuscope::sim {

// "what: strerror(errno)", read at the call.
std::string errno_message(const std::string& what);

// The bytes followed by their CRC-16/MODBUS, low byte first.
std::vector<std::uint8_t> with_crc(std::vector<std::uint8_t> body);

// Writes all of `bytes` to a non-blocking fd, waiting (poll) while it is full. False on
// error or after `timeout` without progress.
bool write_all(int fd, const std::vector<std::uint8_t>& bytes,
               std::chrono::milliseconds timeout = std::chrono::milliseconds(1000));

// libmodbus sets only the baud rates that have a B* constant (B9600 for any other): a rate
// without one is set on its port `fd` as a custom rate, so that the bus's receivers take
// the device at the line's speed.
void set_line_speed(int fd, std::uint32_t baud);

// The input baud rate and stop bits that whoever opened a pseudo-terminal's slave set,
// read through its master (Linux answers a master's termios requests with its slave's).
// Linux ptys force 8 data bits without parity, so those cannot be read. None when the
// settings cannot be read.
struct PtyLine {
    std::uint32_t baud = 0;
    std::uint8_t stop_bits = 1;
};
std::optional<PtyLine> read_pty_line(int master);

// Splits the byte stream of a bus into frames by their CRC. A device hears every request
// and every other device's answer; libmodbus's own receiver parses each frame as a request
// and misframes the others' answers (a 63-byte answer read as an 8-byte request leaves 55
// bytes that it then reads as more requests, sometimes swallowing the next real one). Here
// the lengths a frame can have are derived from its function code (request or answer),
// and the one whose CRC checks wins; bytes that start no frame are skipped one at a time.
class FrameSplitter {
  public:
    void push(const std::uint8_t* data, std::size_t size);
    // The next complete frame (with its CRC), if any. `flush` after the line has been quiet:
    // a frame still incomplete then never will be, so its first byte is skipped.
    std::optional<std::vector<std::uint8_t>> next(bool flush = false);
    [[nodiscard]] bool empty() const { return buffer_.empty(); }

  private:
    std::vector<std::uint8_t> buffer_;
};

}  // namespace rtuscope::sim
