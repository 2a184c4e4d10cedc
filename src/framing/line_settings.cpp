#include "framing/line_settings.hpp"

#include <fmt/format.h>

#include <array>
#include <cctype>
#include <charconv>
#include <cmath>

namespace rtuscope {

unsigned LineSettings::bits_per_char() const {
    return 1U + data_bits + (parity == 'N' ? 0U : 1U) + stop_bits;
}

Nanos LineSettings::char_time() const {
    return static_cast<Nanos>(bits_per_char()) * kNanosPerSecond / static_cast<Nanos>(baud);
}

// Above 19200 baud the specification fixes t1.5 and t3.5 so that fast lines do not need
// sub-millisecond timers.
Nanos LineSettings::t15() const {
    return baud > 19200 ? 750'000 : char_time() * 3 / 2;
}
Nanos LineSettings::t35() const {
    return baud > 19200 ? 1'750'000 : char_time() * 7 / 2;
}

std::string LineSettings::format() const {
    return fmt::format("{}{}{}", data_bits, parity, stop_bits);
}

Result<LineSettings> parse_line_format(std::string_view text, LineSettings base) {
    auto bad = [&] {
        return Error{
            fmt::format("bad line format \"{}\" (expected data bits 5-8, parity N/E/O, "
                        "stop bits 1-2, e.g. 8N1 or 8E1)",
                        text)};
    };
    if (text.size() != 3) return bad();
    const char data = text[0];
    const auto parity = static_cast<char>(std::toupper(static_cast<unsigned char>(text[1])));
    const char stop = text[2];
    if (data < '5' || data > '8') return bad();
    if (parity != 'N' && parity != 'E' && parity != 'O') return bad();
    if (stop != '1' && stop != '2') return bad();
    base.data_bits = static_cast<std::uint8_t>(data - '0');
    base.parity = parity;
    base.stop_bits = static_cast<std::uint8_t>(stop - '0');
    return base;
}

Result<std::uint32_t> parse_baud(std::string_view text) {
    std::uint32_t baud = 0;
    const auto* end = text.data() + text.size();
    const auto [ptr, ec] = std::from_chars(text.data(), end, baud);
    if (ec != std::errc{} || ptr != end || baud < 50 || baud > 4'000'000) {
        return Error{
            fmt::format("bad baud rate \"{}\" (expected a number from 50 to 4000000)", text)};
    }
    return baud;
}

Result<LineSettings> parse_line_settings(std::string_view text) {
    const auto space = text.find(' ');
    if (space == std::string_view::npos) {
        return Error{
            fmt::format("bad line \"{}\" (expected baud and format, e.g. \"9600 8N1\")", text)};
    }
    auto baud = parse_baud(text.substr(0, space));
    if (!baud) return baud.error();
    std::string_view format = text.substr(space);
    while (!format.empty() && format.front() == ' ') format.remove_prefix(1);
    auto line = parse_line_format(format);
    if (!line) return line.error();
    line->baud = *baud;
    return line;
}

namespace {
constexpr std::array<std::uint32_t, 14> kStandardBauds = {1200,   2400,   4800,   9600,  14400,
                                                          19200,  28800,  38400,  57600, 76800,
                                                          115200, 230400, 460800, 921600};
}  // namespace

std::uint32_t nearest_standard_baud(double baud) {
    std::uint32_t nearest = kStandardBauds.front();
    for (const std::uint32_t b : kStandardBauds) {
        if (std::abs(std::log(b / baud)) < std::abs(std::log(nearest / baud))) nearest = b;
    }
    return nearest;
}

std::uint32_t standard_baud_at_least(double baud) {
    for (const std::uint32_t b : kStandardBauds) {
        if (b >= baud) return b;
    }
    return kStandardBauds.back();
}

}  // namespace rtuscope
