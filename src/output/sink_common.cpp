#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <system_error>

#include "output/sinks.hpp"
#include "util/text_append.hpp"

namespace rtuscope {

namespace {
[[noreturn]] void throw_output_error(int error) {
    throw std::system_error(error, std::generic_category(), "cannot write the output");
}
}  // namespace

void write_output(std::FILE* file, std::string_view text) {
    if (std::fwrite(text.data(), 1, text.size(), file) != text.size()) throw_output_error(errno);
}

void flush_output(std::FILE* file) {
    if (std::fflush(file) != 0) throw_output_error(errno);
}

void append_hex(std::string& out, std::span<const std::uint8_t> bytes, bool spaced) {
    append_with(out, 3 * bytes.size(), [&](char* p) { return write_hex(p, bytes, spaced); });
}

std::string hex_bytes(std::span<const std::uint8_t> bytes, bool spaced) {
    std::string text;
    append_hex(text, bytes, spaced);
    return text;
}

void append_seconds(std::string& out, Nanos time) {
    append_with(out, kMaxSecondsChars, [&](char* p) { return write_seconds(p, time); });
}

std::string seconds_text(Nanos time) {
    std::string text;
    append_seconds(text, time);
    return text;
}

void append_csv_field(std::string& out, std::string_view text) {
    append_with(out, 2 * text.size() + 2, [&](char* p) { return write_csv_field(p, text); });
}

std::string csv_field(std::string_view text) {
    std::string field;
    append_csv_field(field, text);
    return field;
}

void append_summary(std::string& out, const Record& record) {
    if (record.kind == Kind::noise) {
        fmt::format_to(std::back_inserter(out), "noise, {} byte{}", record.frame.bytes.size(),
                       record.frame.bytes.size() == 1 ? "" : "s");
        return;
    }
    const DecodedPdu& d = record.decoded;
    out += d.function_name;
    if (!d.summary.empty()) {
        out += ' ';
        out += d.summary;
    }
}

std::string record_summary(const Record& record) {
    std::string text;
    append_summary(text, record);
    return text;
}

void append_unlisted_registers_text(std::string& out, std::size_t count) {
    fmt::format_to(std::back_inserter(out), "{} register{} not in the profile", count,
                   count == 1 ? "" : "s");
}

namespace {

// The length of the well-formed UTF-8 sequence `text` starts with (RFC 3629: no overlong
// forms, no surrogates, nothing above U+10FFFF), or 0 when it starts with none.
std::size_t utf8_sequence_length(std::string_view text) {
    auto byte = [&](std::size_t i) { return static_cast<unsigned char>(text[i]); };
    const unsigned lead = byte(0);
    std::size_t n = 0;
    unsigned low = 0x80;
    unsigned high = 0xBF;
    if (lead >= 0xC2 && lead <= 0xDF) {
        n = 2;
    } else if (lead >= 0xE0 && lead <= 0xEF) {
        n = 3;
        if (lead == 0xE0) low = 0xA0;
        if (lead == 0xED) high = 0x9F;
    } else if (lead >= 0xF0 && lead <= 0xF4) {
        n = 4;
        if (lead == 0xF0) low = 0x90;
        if (lead == 0xF4) high = 0x8F;
    } else {
        return 0;
    }
    if (text.size() < n) return 0;
    if (byte(1) < low || byte(1) > high) return 0;
    for (std::size_t i = 2; i < n; ++i) {
        if (byte(i) < 0x80 || byte(i) > 0xBF) return 0;
    }
    return n;
}

// JSON must be UTF-8, but file names and device names may be in any encoding: every byte
// that does not belong to a well-formed sequence becomes U+FFFD before it is
// escaped.
std::string utf8_clean(std::string_view text) {
    std::string out;
    for (std::size_t i = 0; i < text.size();) {
        if (static_cast<unsigned char>(text[i]) < 0x80) {
            out += text[i++];
            continue;
        }
        const std::size_t n = utf8_sequence_length(text.substr(i));
        if (n == 0) {
            out += "\xEF\xBF\xBD";
            ++i;
        } else {
            out += text.substr(i, n);
            i += n;
        }
    }
    return out;
}

}  // namespace

std::string json_string(std::string_view raw) {
    const std::string text = utf8_clean(raw);
    std::string out = "\"";
    for (const char c : text) {
        switch (c) {
            case '"':
                out += "\\\"";
                break;
            case '\\':
                out += "\\\\";
                break;
            case '\n':
                out += "\\n";
                break;
            case '\r':
                out += "\\r";
                break;
            case '\t':
                out += "\\t";
                break;
            default:
                // Other control characters escaped; bytes >= 0x80 are UTF-8 and pass.
                if (static_cast<unsigned char>(c) < 0x20) {
                    out += fmt::format("\\u{:04x}", static_cast<unsigned>(c));
                } else {
                    out += c;
                }
        }
    }
    out += '"';
    return out;
}

void append_json_string(std::string& out, std::string_view text) {
    // Printable ASCII other than " and \ is written as it is: no need to clean or escape.
    const bool plain = std::all_of(text.begin(), text.end(), [](char c) {
        return c >= 0x20 && c < 0x7F && c != '"' && c != '\\';
    });
    if (!plain) {
        out += json_string(text);
        return;
    }
    out += '"';
    out += text;
    out += '"';
}

}  // namespace rtuscope
