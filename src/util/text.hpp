// Numbers, bytes and times as text, the one way rtuscope writes them. Text is built by
// appending to a std::string that keeps its buffer record after record (append_*). The
// append_* functions are made of write_* functions, which write at `p` (room for their
// bound) and return the end of what they wrote: the CSV sink writes its rows straight into
// its output block with them. Hand-tuned, without format strings or per-character appends:
// the decoder and the sinks run once per frame, and parsing "{}" and std::string's
// out-of-line push_back for every character would be a large part of a decode's time.
#pragma once

#include <fmt/compile.h>
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <memory>
#include <span>
#include <string>
#include <string_view>

#include "util/time.hpp"

namespace rtuscope {

inline constexpr std::size_t kMaxUintChars = 20;

// `one` for 1, else `many`: "1 register", "2 registers".
inline std::string_view plural(std::uint64_t n, std::string_view one, std::string_view many) {
    return n == 1 ? one : many;
}

// The two digits of 0-99, at 2 * n.
inline constexpr auto kTwoDigits = [] {
    std::array<char, 200> pairs{};
    for (std::size_t n = 0; n < 100; ++n) {
        pairs[2 * n] = static_cast<char>('0' + n / 10);
        pairs[2 * n + 1] = static_cast<char>('0' + n % 10);
    }
    return pairs;
}();

inline char* write_uint(char* p, std::uint64_t value) {
    // Hand-tuned: slave addresses, function codes, counts are mostly small, and fmt's
    // general path for them makes a CSV decode 5 % slower.
    if (value < 10) {
        *p = static_cast<char>('0' + value);
        return p + 1;
    }
    if (value < 100) {
        std::memcpy(p, &kTwoDigits[2 * value], 2);
        return p + 2;
    }
    return fmt::format_to(p, FMT_COMPILE("{}"), value);
}

// Exactly `digits` digits, zero-padded: the fraction of a time, a clock field. Two digits
// a step from a table: every record's time has six.
inline char* write_digits(char* p, std::uint64_t value, int digits) {
    int i = digits;
    for (; i >= 2; i -= 2, value /= 100) std::memcpy(p + i - 2, &kTwoDigits[2 * (value % 100)], 2);
    if (i == 1) p[0] = static_cast<char>('0' + value % 10);
    return p + digits;
}

inline char* write_text(char* p, std::string_view text) {
    std::memcpy(p, text.data(), text.size());
    return p + text.size();
}

// A byte's two hex digits, at 2 * byte: both digits of a byte come from one table entry
// (every frame's bytes and every register in a summary are written so).
inline constexpr auto kHexPairs = [] {
    constexpr char kDigits[] = "0123456789ABCDEF";
    std::array<char, 512> pairs{};
    for (std::size_t b = 0; b < 256; ++b) {
        pairs[2 * b] = kDigits[b >> 4];
        pairs[2 * b + 1] = kDigits[b & 0xFU];
    }
    return pairs;
}();

// Two digits per byte, and a space between bytes when `spaced`: at most 3 per byte.
inline char* write_hex(char* p, std::span<const std::uint8_t> bytes, bool spaced) {
    for (std::size_t i = 0; i < bytes.size(); ++i) {
        if (spaced && i > 0) *p++ = ' ';
        std::memcpy(p, &kHexPairs[2 * std::size_t{bytes[i]}], 2);
        p += 2;
    }
    return p;
}

// Seconds with 6 decimals, rounded to the microsecond ("1763798400.022360"), nothing
// without a time; at most 28 characters. Integer arithmetic: no floating point, no locale.
inline constexpr std::size_t kMaxSecondsChars = 28;
inline char* write_seconds(char* p, Nanos time) {
    if (!has_time(time)) return p;
    const bool negative = time < 0;
    const auto magnitude = static_cast<std::uint64_t>(negative ? -(time + 1) + 1 : time);
    const std::uint64_t micros = (magnitude + 500) / 1000;
    if (negative) *p++ = '-';
    p = write_uint(p, micros / 1'000'000);
    *p++ = '.';
    return write_digits(p, micros % 1'000'000, 6);
}

// Milliseconds with 2 or 3 decimals, exactly as fmt's "{:.2f}"/"{:.3f}" write ns / 1e6
// ("12.345", "-0.004"); at most kMaxMillisChars characters. Integer arithmetic, except
// where the double's own rounding decides: a value halfway between two outputs (and
// one beyond 18 minutes) is left to fmt.
inline constexpr std::size_t kMaxMillisChars = 32;
inline char* write_millis(char* p, Nanos duration, int decimals) {
    const std::uint64_t unit = decimals == 2 ? 10'000 : 1'000;  // ns per last digit
    const bool negative = duration < 0;
    const std::uint64_t magnitude = negative
                                        ? std::uint64_t{0} - static_cast<std::uint64_t>(duration)
                                        : static_cast<std::uint64_t>(duration);
    if (magnitude % unit == unit / 2 || magnitude >= (std::uint64_t{1} << 40)) {
        return fmt::format_to(p, "{:.{}f}", static_cast<double>(duration) / 1e6, decimals);
    }
    const std::uint64_t steps = (magnitude + unit / 2) / unit;
    const std::uint64_t steps_per_ms = 1'000'000 / unit;
    if (negative) *p++ = '-';
    p = write_uint(p, steps / steps_per_ms);
    *p++ = '.';
    return write_digits(p, steps % steps_per_ms, decimals);
}

// Appends through one of the writers above, at most `bound` characters: written on the
// stack and appended in one go when they fit there (one capacity check and one copy per
// piece), else into room made at the end of `out` and then trimmed.
template <typename Write>
void append_with(std::string& out, std::size_t bound, Write write) {
    constexpr std::size_t kStackChars = 192;
    if (bound <= kStackChars) {
        char text[kStackChars];
        out.append(text, static_cast<std::size_t>(write(text) - text));
        return;
    }
    const std::size_t at = out.size();
    out.resize(at + bound);
    char* const end = write(out.data() + at);
    out.resize(static_cast<std::size_t>(end - out.data()));
}

inline void append_uint(std::string& out, std::uint64_t value) {
    const fmt::format_int text(value);
    out.append(text.data(), text.size());
}

// `text` padded with spaces to `width` columns, on the left (right-aligned) or the right,
// as fmt's "{:>N}" / "{:<N}" pad it. fmt counts columns, not bytes, for non-ASCII text:
// such text is left to fmt.
inline void append_padded(std::string& out, std::string_view text, std::size_t width,
                          bool right_aligned) {
    const bool ascii = std::all_of(text.begin(), text.end(),
                                   [](char c) { return static_cast<unsigned char>(c) < 0x80; });
    if (!ascii) {
        if (right_aligned) {
            fmt::format_to(std::back_inserter(out), "{:>{}}", text, width);
        } else {
            fmt::format_to(std::back_inserter(out), "{:<{}}", text, width);
        }
        return;
    }
    const std::size_t padding = width > text.size() ? width - text.size() : 0;
    if (right_aligned) out.append(padding, ' ');
    out += text;
    if (!right_aligned) out.append(padding, ' ');
}

inline void append_padded(std::string& out, std::uint64_t value, std::size_t width) {
    const fmt::format_int text(value);
    append_padded(out, std::string_view(text.data(), text.size()), width, true);
}

// "0x1A2B": 6 characters.
inline char* write_hex4(char* p, std::uint16_t value) {
    p[0] = '0';
    p[1] = 'x';
    std::memcpy(p + 2, &kHexPairs[2 * std::size_t{static_cast<std::uint8_t>(value >> 8U)}], 2);
    std::memcpy(p + 4, &kHexPairs[2 * std::size_t{static_cast<std::uint8_t>(value)}], 2);
    return p + 6;
}

inline void append_hex4(std::string& out, std::uint16_t value) {
    char text[6];
    out.append(text, write_hex4(text, value));
}

// "01 03 00 00" (spaced) or "01030000".
inline void append_hex(std::string& out, std::span<const std::uint8_t> bytes, bool spaced) {
    append_with(out, 3 * bytes.size(), [&](char* p) { return write_hex(p, bytes, spaced); });
}

// Seconds with 6 decimals in the input's timebase ("1763798400.022360"); nothing if none.
inline void append_seconds(std::string& out, Nanos time) {
    append_with(out, kMaxSecondsChars, [&](char* p) { return write_seconds(p, time); });
}

// Milliseconds with 2 or 3 decimals ("12.345").
inline void append_millis(std::string& out, Nanos duration, int decimals) {
    append_with(out, kMaxMillisChars, [&](char* p) { return write_millis(p, duration, decimals); });
}

}  // namespace rtuscope
