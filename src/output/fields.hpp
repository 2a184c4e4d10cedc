// Fields as the machine-readable outputs need them: RFC 4180 CSV fields (quoted when they
// must be) and RFC 8259 JSON strings.
#pragma once

#include <array>
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>

#include "util/text.hpp"

namespace rtuscope {

// The characters that make an RFC 4180 field need quotes.
inline constexpr auto kCsvSpecial = [] {
    std::array<bool, 256> special{};
    special[','] = special['"'] = special['\r'] = special['\n'] = true;
    return special;
}();

inline bool is_csv_special(char c) {
    return kCsvSpecial[static_cast<unsigned char>(c)];
}

// Whether any of 16 characters is one of them. Compared as one vector (the compiler's
// vector extension: SSE2 on x86-64, NEON on ARM), not one by one.
inline bool holds_csv_special(const char* sixteen) {
    using Block = char __attribute__((vector_size(16)));
    Block block;
    std::memcpy(&block, sixteen, sizeof block);
    const auto hits = (block == ',') | (block == '"') | (block == '\r') | (block == '\n');
    std::uint64_t halves[2];
    std::memcpy(halves, &hits, sizeof halves);
    return (halves[0] | halves[1]) != 0;
}

// Writes `text` with its quotes doubled (the inside of a quoted field).
inline char* write_doubling_quotes(char* p, std::string_view text) {
    for (const char c : text) {
        if (c == '"') *p++ = '"';
        *p++ = c;
    }
    return p;
}

// Copies `text` to `p` and moves `p` past it, unless it holds a character that needs
// quotes: then false, with what was copied left for the caller to overwrite. Hand-tuned:
// 16 characters a step (checked one by one, a CSV decode takes 10 % longer); the last step
// overlaps the one before rather than going on one character at a time.
inline bool copy_if_unquoted(char*& p, std::string_view text) {
    const char* const s = text.data();
    const std::size_t n = text.size();
    if (n < 16) {
        for (std::size_t i = 0; i < n; ++i) {
            if (is_csv_special(s[i])) return false;
            p[i] = s[i];
        }
        p += n;
        return true;
    }
    for (std::size_t i = 0;; i += 16) {
        if (i + 16 > n) i = n - 16;
        if (holds_csv_special(s + i)) return false;
        std::memcpy(p + i, s + i, 16);
        if (i + 16 == n) {
            p += n;
            return true;
        }
    }
}

// The RFC 4180 field `first` + " " + `second` (just `first` when `second` is empty),
// without joining the two first: quoted when either holds a comma, a quote or a line
// break; at most 2 * (both sizes + 1) + 2 characters.
inline char* write_csv_field(char* p, std::string_view first, std::string_view second) {
    char* end = p;
    if (copy_if_unquoted(end, first)) {
        if (second.empty()) return end;
        *end++ = ' ';
        if (copy_if_unquoted(end, second)) return end;
    }
    *p++ = '"';
    p = write_doubling_quotes(p, first);
    if (!second.empty()) {
        *p++ = ' ';
        p = write_doubling_quotes(p, second);
    }
    *p++ = '"';
    return p;
}

// An RFC 4180 field, quoted when it holds a comma, a quote or a line break; at most
// 2 * size + 2 characters.
inline char* write_csv_field(char* p, std::string_view text) {
    return write_csv_field(p, text, {});
}

// An RFC 4180 field, quoted when it holds a comma, a quote or a line break.
inline void append_csv_field(std::string& out, std::string_view text) {
    append_with(out, 2 * text.size() + 2, [&](char* p) { return write_csv_field(p, text); });
}

// A JSON string literal, quotes included (RFC 8259 escapes); bytes that are not UTF-8
// become U+FFFD, as JSON must be UTF-8.
void append_json_string(std::string& out, std::string_view text);

}  // namespace rtuscope
