// CRC-16/MODBUS (poly 0x8005 reflected = 0xA001, init 0xFFFF, no final xor), sent low
// byte first (Modbus over Serial Line v1.02, 2.5.1.2 and appendix B).
#pragma once

#include <array>
#include <cstdint>
#include <span>

namespace rtuscope {

std::uint16_t crc16_modbus(std::span<const std::uint8_t> bytes);
// Continues a CRC over more bytes: crc16_modbus(a + b) == crc16_modbus_update(crc16_modbus(a), b).
std::uint16_t crc16_modbus_update(std::uint16_t crc, std::span<const std::uint8_t> bytes);

namespace detail {
// Slicing-by-8 tables (see crc.cpp); [0] is the classic byte table.
using CrcTables = std::array<std::array<std::uint16_t, 256>, 8>;
extern const CrcTables kCrcTables;
}  // namespace detail

// One byte more, inline: for a search that checks the CRC after every byte.
inline std::uint16_t crc16_modbus_byte(std::uint16_t crc, std::uint8_t byte) {
    return static_cast<std::uint16_t>((crc >> 8) ^ detail::kCrcTables[0][(crc ^ byte) & 0xFFU]);
}

// Two bytes more, inline, with two independent lookups (slicing-by-2).
inline std::uint16_t crc16_modbus_2(std::uint16_t crc, std::uint8_t first, std::uint8_t second) {
    return static_cast<std::uint16_t>(detail::kCrcTables[1][(crc ^ first) & 0xFFU] ^
                                      detail::kCrcTables[0][((crc >> 8) ^ second) & 0xFFU]);
}

enum class CrcStatus : std::uint8_t {
    none,     // not a frame (noise)
    ok,       // last two bytes are the CRC, low byte first
    bad,      // last two bytes are not the CRC of the rest
    swapped,  // last two bytes are the CRC with high and low byte exchanged
};

struct CrcCheck {
    CrcStatus status = CrcStatus::none;
    std::uint16_t expected = 0;  // computed over all but the last two bytes
    std::uint16_t received = 0;  // last two bytes read low byte first
};

// How a frame's last two bytes compare with `expected`, the CRC of all the bytes before
// them. For a caller that has that CRC already (one pass serving two readings).
inline CrcCheck crc_check_of(std::span<const std::uint8_t> frame, std::uint16_t expected) {
    CrcCheck check;
    const std::size_t n = frame.size();
    check.expected = expected;
    check.received = static_cast<std::uint16_t>(frame[n - 2] | (frame[n - 1] << 8));
    const auto swapped = static_cast<std::uint16_t>((expected >> 8) | (expected << 8));
    if (check.received == expected) {
        check.status = CrcStatus::ok;
    } else if (check.received == swapped) {
        check.status = CrcStatus::swapped;
    } else {
        check.status = CrcStatus::bad;
    }
    return check;
}

// A frame of fewer than 3 bytes cannot carry a CRC and checks as bad. Inline: returned
// from a call, the 6-byte result was packed through the stack and read back whole, a
// store-forwarding stall that cost more than the CRC of a short frame.
inline CrcCheck check_crc(std::span<const std::uint8_t> frame) {
    if (frame.size() < 3) {
        CrcCheck check;
        check.status = CrcStatus::bad;
        return check;
    }
    return crc_check_of(frame, crc16_modbus(frame.first(frame.size() - 2)));
}

const char* to_string(CrcStatus status);

}  // namespace rtuscope
