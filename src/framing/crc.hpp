// CRC-16/MODBUS (poly 0x8005 reflected = 0xA001, init 0xFFFF, no final xor), sent low
// byte first (Modbus over Serial Line v1.02, 2.5.1.2 and appendix B).
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string_view>

namespace rtuscope {

namespace detail {
// Slicing-by-8 tables (see crc.cpp); [0] is the classic byte table.
using CrcTables = std::array<std::array<std::uint16_t, 256>, 8>;
extern const CrcTables kCrcTables;

// The classic byte table: entry i is the register after byte i, bit by bit. Constexpr for
// the tables made at compile time from it (kCrcTables, the CRC end index's).
constexpr std::array<std::uint16_t, 256> make_crc_byte_table() {
    std::array<std::uint16_t, 256> table{};
    for (unsigned i = 0; i < 256; ++i) {
        auto crc = static_cast<std::uint16_t>(i);
        for (int bit = 0; bit < 8; ++bit) {
            crc = (crc & 1U) ? static_cast<std::uint16_t>((crc >> 1) ^ 0xA001U)
                             : static_cast<std::uint16_t>(crc >> 1);
        }
        table[i] = crc;
    }
    return table;
}
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

// Four bytes more, with the CRC after each of them: [3] is the CRC after all four, by
// four independent lookups (slicing-by-4); [0]-[2], after one, two and three of them,
// branch off it by lookups of their own. For a search that tests every length, four
// lengths a step.
inline std::array<std::uint16_t, 4> crc16_modbus_each_of_4(std::uint16_t crc,
                                                           const std::uint8_t* bytes) {
    const auto& tables = detail::kCrcTables;
    const auto b0 = static_cast<std::uint8_t>(bytes[0] ^ (crc & 0xFFU));
    const auto b1 = static_cast<std::uint8_t>(bytes[1] ^ (crc >> 8));
    return {static_cast<std::uint16_t>((crc >> 8) ^ tables[0][b0]),
            static_cast<std::uint16_t>(tables[1][b0] ^ tables[0][b1]),
            static_cast<std::uint16_t>(tables[2][b0] ^ tables[1][b1] ^ tables[0][bytes[2]]),
            static_cast<std::uint16_t>(tables[3][b0] ^ tables[2][b1] ^ tables[1][bytes[2]] ^
                                       tables[0][bytes[3]])};
}

// Continues a CRC over more bytes: crc16_modbus(a + b) == crc16_modbus_update(crc16_modbus(a), b).
// Inline: frames are short, and called for each of a position's readings the call and
// the loop's set-up cost as much as the bytes.
inline std::uint16_t crc16_modbus_update(std::uint16_t crc, std::span<const std::uint8_t> bytes) {
    const auto& tables = detail::kCrcTables;
    const std::uint8_t* p = bytes.data();
    std::size_t n = bytes.size();
    while (n >= 8) {
        // The 16-bit CRC only overlaps the first two of the eight bytes.
        const auto b0 = static_cast<std::uint8_t>(p[0] ^ (crc & 0xFFU));
        const auto b1 = static_cast<std::uint8_t>(p[1] ^ (crc >> 8));
        crc = static_cast<std::uint16_t>(tables[7][b0] ^ tables[6][b1] ^ tables[5][p[2]] ^
                                         tables[4][p[3]] ^ tables[3][p[4]] ^ tables[2][p[5]] ^
                                         tables[1][p[6]] ^ tables[0][p[7]]);
        p += 8;
        n -= 8;
    }
    // Frames are short: most of one is this tail, so it too goes in steps of 4 and 2.
    if (n >= 4) {
        const auto b0 = static_cast<std::uint8_t>(p[0] ^ (crc & 0xFFU));
        const auto b1 = static_cast<std::uint8_t>(p[1] ^ (crc >> 8));
        crc = static_cast<std::uint16_t>(tables[3][b0] ^ tables[2][b1] ^ tables[1][p[2]] ^
                                         tables[0][p[3]]);
        p += 4;
        n -= 4;
    }
    if (n >= 2) {
        crc = crc16_modbus_2(crc, p[0], p[1]);
        p += 2;
        n -= 2;
    }
    if (n == 1) crc = crc16_modbus_byte(crc, *p);
    return crc;
}

inline std::uint16_t crc16_modbus(std::span<const std::uint8_t> bytes) {
    return crc16_modbus_update(0xFFFF, bytes);
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
// from a call, the 6-byte result is packed through the stack and read back whole, a
// store-forwarding stall that costs more than the CRC of a short frame.
inline CrcCheck check_crc(std::span<const std::uint8_t> frame) {
    if (frame.size() < 3) {
        CrcCheck check;
        check.status = CrcStatus::bad;
        return check;
    }
    return crc_check_of(frame, crc16_modbus(frame.first(frame.size() - 2)));
}

std::string_view to_string(CrcStatus status);

}  // namespace rtuscope
