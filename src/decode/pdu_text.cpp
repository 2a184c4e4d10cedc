#include "decode/pdu_text.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "util/text.hpp"

namespace rtuscope {
namespace {

// " ... (+12 more)" after a list cut short.
char* write_more(char* p, std::size_t more) {
    p = write_text(p, " ... (+");
    p = write_uint(p, more);
    return write_text(p, " more)");
}
constexpr std::size_t kMaxMoreChars = kMaxUintChars + 14;
constexpr std::size_t kMaxWordListChars = 7 * kListedWords + kMaxMoreChars;
constexpr std::size_t kMaxBitListChars = kListedBits + kMaxMoreChars;
constexpr std::size_t kMaxValuesChars = 2 + std::max(kMaxWordListChars, kMaxBitListChars);

char* write_word_list(char* p, std::span<const std::uint16_t> values) {
    const std::size_t listed = std::min(values.size(), kListedWords);
    if (listed != 0) p = write_hex4(p, values[0]);
    for (std::size_t i = 1; i < listed; ++i) {
        *p++ = ' ';
        p = write_hex4(p, values[i]);
    }
    if (values.size() > listed) p = write_more(p, values.size() - listed);
    return p;
}

char* write_bit_list(char* p, std::span<const std::uint16_t> bits) {
    const std::size_t listed = std::min(bits.size(), kListedBits);
    for (std::size_t i = 0; i < listed; ++i) *p++ = bits[i] != 0 ? '1' : '0';
    if (bits.size() > listed) p = write_more(p, bits.size() - listed);
    return p;
}

char* write_values(char* p, std::span<const std::uint16_t> values, bool as_bits) {
    if (values.empty()) return p;
    p = write_text(p, ": ");
    return as_bits ? write_bit_list(p, values) : write_word_list(p, values);
}

char* write_counted(char* p, std::size_t n, std::string_view one, std::string_view many) {
    p = write_uint(p, n);
    *p++ = ' ';
    return write_text(p, plural(n, one, many));
}

std::size_t counted_bound(std::string_view one, std::string_view many) {
    return kMaxUintChars + 1 + std::max(one.size(), many.size());
}

}  // namespace

void append_counted(std::string& out, std::size_t n, std::string_view one, std::string_view many) {
    append_with(out, counted_bound(one, many),
                [&](char* p) { return write_counted(p, n, one, many); });
}

void append_word_list(std::string& out, std::span<const std::uint16_t> values) {
    append_with(out, kMaxWordListChars, [&](char* p) { return write_word_list(p, values); });
}

void append_values(std::string& out, std::span<const std::uint16_t> values, bool as_bits) {
    append_with(out, kMaxValuesChars, [&](char* p) { return write_values(p, values, as_bits); });
}

void append_listed(std::string& out, std::span<const std::uint16_t> values, std::string_view one,
                   std::string_view many, bool as_bits) {
    append_with(out, counted_bound(one, many) + kMaxValuesChars, [&](char* p) {
        return write_values(write_counted(p, values.size(), one, many), values, as_bits);
    });
}

void append_range(std::string& out, std::optional<std::uint16_t> start,
                  std::optional<std::uint16_t> qty) {
    append_with(out, 6 + 2 + 5, [&](char* p) {
        if (start) p = write_hex4(p, *start);
        if (qty) {
            p = write_text(p, start ? " x" : "x");
            p = write_uint(p, *qty);
        }
        return p;
    });
}

void append_quoted(std::string& out, std::span<const std::uint8_t> bytes) {
    out += '"';
    for (std::uint8_t c : bytes) {
        if (c == '"' || c == '\\') {
            out += '\\';
            out += static_cast<char>(c);
        } else if (c >= 0x20 && c < 0x7F) {
            out += static_cast<char>(c);
        } else {
            fmt::format_to(std::back_inserter(out), "\\x{:02X}", c);
        }
    }
    out += '"';
}

void append_separator(std::string& out, std::string_view separator) {
    if (!out.empty()) out += separator;
}

void words_of(std::span<const std::uint8_t> bytes, std::vector<std::uint16_t>& words) {
    // Sized once and filled through a pointer: a push_back per value checks the capacity
    // every time.
    const std::size_t n = bytes.size() / 2;
    words.resize(n);
    std::uint16_t* const out = words.data();
    for (std::size_t i = 0; i < n; ++i) {
        out[i] = static_cast<std::uint16_t>((bytes[2 * i] << 8) | bytes[2 * i + 1]);
    }
}

void bits_of(std::span<const std::uint8_t> bytes, std::size_t count,
             std::vector<std::uint16_t>& bits) {
    count = std::min(count, bytes.size() * 8);
    bits.resize(count);
    std::uint16_t* const out = bits.data();
    for (std::size_t first = 0; first < count; first += 8) {
        const unsigned byte = bytes[first / 8];
        const std::size_t n = std::min<std::size_t>(8, count - first);
        for (std::size_t bit = 0; bit < n; ++bit) {
            out[first + bit] = static_cast<std::uint16_t>((byte >> bit) & 1U);
        }
    }
}

}  // namespace rtuscope
