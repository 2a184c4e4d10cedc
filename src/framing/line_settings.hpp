// Serial line settings and the Modbus-over-serial-line timing derived from them
// (Modbus over Serial Line v1.02, 2.5.1.1: t1.5 and t3.5 character times, fixed at
// 750 us and 1750 us above 19200 baud).
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "util/result.hpp"
#include "util/time.hpp"

namespace rtuscope {

struct LineSettings {
    std::uint32_t baud = 9600;
    std::uint8_t data_bits = 8;
    char parity = 'N';  // 'N', 'E' or 'O'
    std::uint8_t stop_bits = 1;

    // start + data + parity + stop bits
    [[nodiscard]] unsigned bits_per_char() const;
    [[nodiscard]] Nanos char_time() const;
    [[nodiscard]] Nanos t15() const;
    [[nodiscard]] Nanos t35() const;
    // "8N1"
    [[nodiscard]] std::string format() const;
};

// "8N1", "8E1", "7E1", "8N2", case-insensitive.
Result<LineSettings> parse_line_format(std::string_view text, LineSettings base = {});
Result<std::uint32_t> parse_baud(std::string_view text);
// "9600 8E1": baud rate and format, as profiles and bus files give them.
Result<LineSettings> parse_line_settings(std::string_view text);

// The standard rate nearest to `baud` (by ratio), and the lowest standard rate at least
// `baud` (the highest when none is).
std::uint32_t nearest_standard_baud(double baud);
std::uint32_t standard_baud_at_least(double baud);

}  // namespace rtuscope
