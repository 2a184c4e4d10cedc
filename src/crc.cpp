// CRC-16/MODBUS, table-driven (one table lookup per byte).
#include "rtuscope/crc.hpp"

#include <array>

namespace rtuscope {
namespace {

constexpr std::array<std::uint16_t, 256> make_table() {
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

constexpr auto kTable = make_table();

}  // namespace

std::uint16_t crc16_modbus(std::span<const std::uint8_t> bytes) {
    return crc16_modbus_update(0xFFFF, bytes);
}

std::uint16_t crc16_modbus_update(std::uint16_t crc, std::span<const std::uint8_t> bytes) {
    for (std::uint8_t b : bytes) {
        crc = static_cast<std::uint16_t>((crc >> 8) ^ kTable[(crc ^ b) & 0xFFU]);
    }
    return crc;
}

CrcCheck check_crc(std::span<const std::uint8_t> frame) {
    CrcCheck check;
    if (frame.size() < 3) {
        check.status = CrcStatus::bad;
        return check;
    }
    const std::size_t n = frame.size();
    check.expected = crc16_modbus(frame.first(n - 2));
    check.received = static_cast<std::uint16_t>(frame[n - 2] | (frame[n - 1] << 8));
    const auto swapped = static_cast<std::uint16_t>((check.expected >> 8) | (check.expected << 8));
    if (check.received == check.expected) {
        check.status = CrcStatus::ok;
    } else if (check.received == swapped) {
        check.status = CrcStatus::swapped;
    } else {
        check.status = CrcStatus::bad;
    }
    return check;
}

const char* to_string(CrcStatus status) {
    switch (status) {
        case CrcStatus::none:
            return "";
        case CrcStatus::ok:
            return "ok";
        case CrcStatus::bad:
            return "bad";
        case CrcStatus::swapped:
            return "swapped";
    }
    return "";
}

}  // namespace rtuscope
