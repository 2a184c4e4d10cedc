#include <fmt/format.h>

#include "rtuscope/sinks.hpp"

namespace rtuscope {

std::string hex_bytes(std::span<const std::uint8_t> bytes, bool spaced) {
    static constexpr char kDigits[] = "0123456789ABCDEF";
    std::string text;
    text.reserve(bytes.size() * 3);
    for (std::size_t i = 0; i < bytes.size(); ++i) {
        if (spaced && i > 0) text.push_back(' ');
        text.push_back(kDigits[bytes[i] >> 4]);
        text.push_back(kDigits[bytes[i] & 0xFU]);
    }
    return text;
}

std::string seconds_text(Nanos time) {
    if (!has_time(time)) return {};
    // Integer arithmetic, rounded to the microsecond: no floating point, no locale.
    const bool negative = time < 0;
    const auto magnitude = static_cast<std::uint64_t>(negative ? -(time + 1) + 1 : time);
    const std::uint64_t micros = (magnitude + 500) / 1000;
    return fmt::format("{}{}.{:06}", negative ? "-" : "", micros / 1'000'000, micros % 1'000'000);
}

std::string csv_field(std::string_view text) {
    if (text.find_first_of(",\"\r\n") == std::string_view::npos) return std::string(text);
    std::string field = "\"";
    for (char c : text) {
        if (c == '"') field += '"';
        field += c;
    }
    field += '"';
    return field;
}

std::string record_summary(const Record& record) {
    if (record.kind == Kind::noise) {
        return fmt::format("noise, {} byte{}", record.frame.bytes.size(),
                           record.frame.bytes.size() == 1 ? "" : "s");
    }
    const DecodedPdu& d = record.decoded;
    std::string text = d.function_name;
    if (!d.summary.empty()) {
        text += ' ';
        text += d.summary;
    }
    return text;
}

}  // namespace rtuscope
