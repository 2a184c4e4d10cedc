// Capture reader: the native text capture format v1 (docs/formats.md, "Native capture format").
//
//   # rtuscope capture v1
//   # serial 9600 8N1
//   1763798400.022360 01 03 00 00 00 02 C4 0B
//   1763798400.038384 @B 01 03 02 17 F8 B6 36
//
// Streams line by line: captures reach a gigabyte, and the chunks before a bad line are
// delivered before its error. Timestamps are parsed digit by digit into integer
// nanoseconds; a double cannot hold 1763798400.022360 exactly.
#include <fmt/format.h>

#include <array>
#include <bit>
#include <charconv>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <optional>

#include "framing/line_settings.hpp"
#include "input/readers.hpp"

namespace rtuscope::detail {
namespace {

constexpr std::string_view kHeader = "# rtuscope capture v1";

bool is_space(char c) {
    return c == ' ' || c == '\t';
}

std::size_t skip_space(std::string_view s, std::size_t i) {
    while (i < s.size() && is_space(s[i])) ++i;
    return i;
}

std::size_t token_end(std::string_view s, std::size_t i) {
    while (i < s.size() && !is_space(s[i])) ++i;
    return i;
}

int column(std::size_t index) {
    return static_cast<int>(index) + 1;
}

bool is_digit(char c) {
    return c >= '0' && c <= '9';
}

enum class TimeParse : std::uint8_t { ok, bad, too_precise, out_of_range };

// The eight ASCII digits at `p` as a number, or false if one of them is no digit. A
// timestamp has 16 to 19 digits; taking them eight at a time saves most of a per-digit
// loop that costs more than the rest of the line but its hex bytes. Only on
// little-endian machines, where the first digit is the lowest byte; elsewhere the
// per-digit loops do it all.
bool eight_digits(const char* p, std::uint64_t& value) {
    if constexpr (std::endian::native != std::endian::little) {
        return false;
    } else {
        constexpr std::uint64_t kAll = 0x0101010101010101;
        std::uint64_t chars = 0;
        std::memcpy(&chars, p, sizeof chars);
        // A digit is 0x30..0x39: high nibble 3, and still 3 after adding 6.
        if (((chars & (0xF0 * kAll)) | (((chars + 6 * kAll) & (0xF0 * kAll)) >> 4)) !=
            0x33 * kAll) {
            return false;
        }
        std::uint64_t v = chars - 0x30 * kAll;
        v = (v * 10 + (v >> 8)) & 0x00FF00FF00FF00FF;    // pairs of digits
        v = (v * 100 + (v >> 16)) & 0x0000FFFF0000FFFF;  // fours
        value = (v * 10000 + (v >> 32)) & 0xFFFFFFFF;
        return true;
    }
}

// The timestamp at the start of `text`, which runs to its end or to a space; `length`
// is set to the timestamp's length. Parsed where it lies: finding the token's end first
// would be a pass over every line for nothing.
TimeParse parse_seconds(std::string_view text, Nanos& out, std::size_t& length) {
    constexpr std::int64_t kMaxSeconds = std::numeric_limits<Nanos>::max() / kNanosPerSecond;
    constexpr std::int64_t kMaxFraction = std::numeric_limits<Nanos>::max() % kNanosPerSecond;
    constexpr std::int64_t kScale[10] = {1'000'000'000, 100'000'000, 10'000'000, 1'000'000, 100'000,
                                         10'000,        1'000,       100,        10,        1};
    std::size_t i = 0;
    const bool negative = !text.empty() && text[0] == '-';
    if (negative) ++i;
    const std::size_t int_begin = i;
    // Exact while at most kMaxSeconds; past that only "too big" matters, and eight more
    // digits on kMaxSeconds still fit in 63 bits.
    std::int64_t seconds = 0;
    bool too_big = false;
    std::uint64_t eight = 0;
    while (text.size() - i >= 8 && eight_digits(text.data() + i, eight)) {
        if (seconds > kMaxSeconds) {
            too_big = true;
        } else {
            seconds = seconds * 100'000'000 + static_cast<std::int64_t>(eight);
        }
        i += 8;
    }
    for (; i < text.size() && is_digit(text[i]); ++i) {
        if (seconds > kMaxSeconds) {
            too_big = true;
        } else {
            seconds = seconds * 10 + (text[i] - '0');
        }
    }
    if (i == int_begin) return TimeParse::bad;
    std::int64_t fraction = 0;
    std::size_t fraction_digits = 0;
    if (i < text.size() && text[i] == '.') {
        ++i;
        const std::size_t fraction_begin = i;
        if (text.size() - i >= 8 && eight_digits(text.data() + i, eight)) {
            fraction = static_cast<std::int64_t>(eight);
            i += 8;
        }
        for (; i < text.size() && is_digit(text[i]); ++i) {
            if (i - fraction_begin < 9) fraction = fraction * 10 + (text[i] - '0');
        }
        fraction_digits = i - fraction_begin;
        if (fraction_digits == 0) return TimeParse::bad;
    }
    if (i != text.size() && !is_space(text[i])) return TimeParse::bad;
    length = i;
    if (fraction_digits > 9) return TimeParse::too_precise;
    fraction *= kScale[fraction_digits];
    if (too_big || seconds > kMaxSeconds || (seconds == kMaxSeconds && fraction > kMaxFraction)) {
        return TimeParse::out_of_range;
    }
    const Nanos value = seconds * kNanosPerSecond + fraction;
    out = negative ? -value : value;
    return TimeParse::ok;
}

// The byte two hex digits stand for, -1 if either is no hex digit; indexed by the two
// characters' low seven bits (a character with the eighth bit set is no hex digit). One
// lookup per byte instead of two lookups, a shift and an or: the hex bytes are most of a
// capture's text. 32 KiB, of which a capture touches a few kilobytes.
constexpr auto kHexPairValues = [] {
    std::array<std::int16_t, std::size_t{128} * 128> table{};
    for (std::size_t first = 0; first < 128; ++first) {
        for (std::size_t second = 0; second < 128; ++second) {
            const int hi = hex_value(static_cast<char>(first));
            const int lo = hex_value(static_cast<char>(second));
            table[first | second << 7] =
                static_cast<std::int16_t>(hi < 0 || lo < 0 ? -1 : hi << 4 | lo);
        }
    }
    return table;
}();

// As hex_pair, for two characters known to be below 0x80.
std::int64_t ascii_hex_pair(const char* p) {
    const auto first = static_cast<unsigned char>(p[0]) & 0x7FU;
    const auto second = static_cast<unsigned char>(p[1]) & 0x7FU;
    return kHexPairValues[first | std::size_t{second} << 7];
}

// The byte the two hex digits at `p` stand for, -1 if they are not two hex digits.
std::int64_t hex_pair(const char* p) {
    if (((static_cast<unsigned char>(p[0]) | static_cast<unsigned char>(p[1])) & 0x80U) != 0) {
        return -1;
    }
    return ascii_hex_pair(p);
}

// Eight bytes of text as one word, for checking several separators at once.
std::uint64_t load_word(const char* p) {
    std::uint64_t word = 0;
    std::memcpy(&word, p, sizeof word);
    return word;
}

// A word's mask selecting the characters marked 'x' of `pattern` (8 characters, as they
// lie in memory). Built from the characters, so it holds whatever the byte order.
constexpr std::uint64_t separator_mask(const char (&pattern)[9]) {
    std::array<char, 8> mask{};
    for (std::size_t k = 0; k < mask.size(); ++k) mask[k] = pattern[k] == 'x' ? '\xFF' : '\0';
    return std::bit_cast<std::uint64_t>(mask);
}

// What the characters a mask selects are when they all are spaces.
constexpr std::uint64_t spaces_under(std::uint64_t mask) {
    return mask & 0x2020202020202020;
}

// The separators of eight bytes "XX XX XX XX XX XX XX XX " in its three words.
constexpr std::uint64_t kSeparators0 = separator_mask("..x..x..");
constexpr std::uint64_t kSeparators1 = separator_mask("x..x..x.");
constexpr std::uint64_t kSeparators2 = separator_mask(".x..x..x");

// Four bytes "XX XX XX XX" at `p` with a separator after each, as a little-endian
// number; negative if any is not two hex digits (the shift of a -1 sets every bit above
// it). The caller has checked that none of the characters is 0x80 or above.
std::int64_t four_hex_bytes(const char* p) {
    return ascii_hex_pair(p) | ascii_hex_pair(p + 3) << 8 | ascii_hex_pair(p + 6) << 16 |
           ascii_hex_pair(p + 9) << 24;
}

class CaptureReader final : public ChunkSource {
  public:
    explicit CaptureReader(std::unique_ptr<InputBuffer> in) : in_(std::move(in)) {
        info_.name = in_->name();
        info_.format = "capture";
        info_.timed = true;
        info_.time_base = TimeBase::relative;
    }

    // Reads the header and the comments after it, so that `# serial` is known before
    // the first chunk; the first data line is kept for next().
    Status open() {
        std::string_view line;
        Result<bool> more = in_->next_line(line);
        if (!more) return more.error();
        if (*more && line.starts_with("\xEF\xBB\xBF")) line.remove_prefix(3);
        if (!*more || !is_header(line)) return header_error(*more ? line : std::string_view{});
        for (;;) {
            more = in_->next_line(line);
            if (!more) return more.error();
            if (!*more) {
                at_end_ = true;
                in_header_ = false;
                return ok_status();
            }
            Result<bool> comment = comment_line(line);
            if (!comment) return comment.error();
            if (!*comment) {
                in_header_ = false;
                pending_ = line;
                has_pending_ = true;
                // Unix time or relative seconds: the first timestamp tells (a bad one is
                // reported when its line is read).
                Nanos first = 0;
                std::size_t length = 0;
                const std::size_t at = skip_space(line, 0);
                if (parse_seconds(line.substr(at), first, length) == TimeParse::ok) {
                    info_.time_base = time_base_of(first);
                }
                return ok_status();
            }
        }
    }

    [[nodiscard]] const SourceInfo& info() const override { return info_; }

    Result<bool> next(Chunk& out) override {
        if (failed_) return *failed_;
        if (has_pending_) {
            has_pending_ = false;
            if (!data_line(pending_, out)) return *failed_;
            return true;
        }
        if (at_end_) return false;
        std::string_view line;
        for (;;) {
            Result<bool> more = in_->next_line(line);
            if (!more) return remember(more);
            if (!*more) {
                at_end_ = true;
                return false;
            }
            // Most lines are data and start with their timestamp's first digit.
            if (line.empty() || !is_digit(line[0])) {
                Result<bool> comment = comment_line(line);
                if (!comment) return remember(comment);
                if (*comment) continue;
            }
            if (!data_line(line, out)) return *failed_;
            stopped_here_ = false;  // a `# stopped` line counts only at the end
            return true;
        }
    }

    [[nodiscard]] bool ended_by_stop() const override { return at_end_ && stopped_here_; }
    [[nodiscard]] std::vector<std::string> remarks() const override { return gaps_; }

  private:
    // The first three words after the '#' of a comment line; false if it is no comment.
    static bool header_words(std::string_view line, std::string_view (&words)[3], bool& more) {
        std::size_t i = skip_space(line, 0);
        if (i >= line.size() || line[i] != '#') return false;
        ++i;
        for (std::string_view& word : words) {
            i = skip_space(line, i);
            const std::size_t e = token_end(line, i);
            word = line.substr(i, e - i);
            i = e;
        }
        more = skip_space(line, i) != line.size();
        return true;
    }

    static bool is_header(std::string_view line) {
        std::string_view words[3];
        bool more = false;
        return header_words(line, words, more) && words[0] == "rtuscope" && words[1] == "capture" &&
               words[2] == "v1" && !more;
    }

    Error header_error(std::string_view line) const {
        std::string message =
            fmt::format("not an rtuscope capture (line 1 must be \"{}\")", kHeader);
        // Name the version when it is only the version that is wrong.
        std::string_view words[3];
        bool more = false;
        if (header_words(line, words, more) && words[0] == "rtuscope" && words[1] == "capture" &&
            words[2] != "v1" && !words[2].empty()) {
            message = fmt::format("unsupported capture version {} (this rtuscope reads v1)",
                                  quote_token(words[2]));
        }
        return Error{std::move(message), info_.name, 1, 1};
    }

    Error error_at(std::size_t index, std::string message) const {
        return Error{std::move(message), info_.name, in_->line_number(), column(index)};
    }

    bool fail(Error error) {
        failed_ = std::move(error);
        return false;
    }

    Result<bool> remember(Result<bool> result) {
        if (!result) failed_ = result.error();
        return result;
    }

    // True for blank and comment lines (reading the header's `# serial`, `# device`,
    // `# profile` on the way), false for data.
    Result<bool> comment_line(std::string_view line) {
        std::size_t i = skip_space(line, 0);
        if (i == line.size()) return true;
        if (line[i] != '#') return false;
        if (in_header_ && embedding_ != nullptr && line.substr(i).starts_with("#|")) {
            std::string_view text = line.substr(i + 2);
            if (text.starts_with(' ')) text.remove_prefix(1);
            embedding_->append(text).append("\n");
            return true;
        }
        i = skip_space(line, i + 1);
        std::size_t e = token_end(line, i);
        const std::string_view word = line.substr(i, e - i);
        if (in_header_ && word != "serial") return header_comment(line, word, e);
        // `# continued in NEXT`: a rotated recording's file ends as a stopped one does,
        // by the recorder, not by the bus.
        if (word == "stopped" || word == "continued") {
            stopped_here_ = true;
            return true;
        }
        if (word == "gap") {
            note_gap(line, e);
            return true;
        }
        if (word != "serial") return true;

        const auto missing = [&](std::size_t at) {
            return error_at(at,
                            "\"# serial\" needs a baud rate and a line format, e.g. "
                            "\"# serial 9600 8N1\"");
        };
        const std::size_t baud_at = skip_space(line, e);
        if (baud_at == line.size()) return missing(e);
        e = token_end(line, baud_at);
        Result<std::uint32_t> baud = parse_baud(line.substr(baud_at, e - baud_at));
        if (!baud) return error_at(baud_at, baud.error().message);
        const std::size_t format_at = skip_space(line, e);
        if (format_at == line.size()) return missing(e);
        e = token_end(line, format_at);
        LineSettings base;
        base.baud = *baud;
        Result<LineSettings> settings =
            parse_line_format(line.substr(format_at, e - format_at), base);
        if (!settings) return error_at(format_at, settings.error().message);
        const std::size_t extra_at = skip_space(line, e);
        if (extra_at != line.size()) {
            const std::string_view extra =
                line.substr(extra_at, token_end(line, extra_at) - extra_at);
            return error_at(extra_at,
                            fmt::format("unexpected {} after the line format", quote_token(extra)));
        }
        settings->baud = *baud;
        info_.line = *settings;
        return true;
    }

    // `# gap FROM TO (...)`, the recorder's note that the port was gone: a remark. A gap
    // line it did not write is a comment like any other.
    void note_gap(std::string_view line, std::size_t e) {
        Nanos from = 0;
        Nanos to = 0;
        std::size_t length = 0;
        const std::size_t from_at = skip_space(line, e);
        if (parse_seconds(line.substr(from_at), from, length) != TimeParse::ok) return;
        const std::size_t to_at = skip_space(line, from_at + length);
        if (parse_seconds(line.substr(to_at), to, length) != TimeParse::ok) return;
        gaps_.push_back(fmt::format(
            "line {}: the port was gone from {} to {} ({:.1f} s) and was opened again: "
            "nothing was heard then",
            in_->line_number(), utc_text(from), utc_text(to), static_cast<double>(to - from) / 1e9));
    }

    // `# written by rtuscope 0.1.0`, `# device 3 pdu485`, `# profile NAME` ... `# end
    // profile` (the profile's lines each behind `#|`): the header's word `word` ends at `e`.
    Result<bool> header_comment(std::string_view line, std::string_view word, std::size_t e) {
        const auto rest = [&](std::size_t from) {
            std::string_view r = line.substr(skip_space(line, from));
            while (!r.empty() && (r.back() == ' ' || r.back() == '\t')) r.remove_suffix(1);
            return r;
        };
        if (word == "written" && rest(e).starts_with("by ")) {
            info_.written_by = std::string(rest(e).substr(3));
        } else if (word == "device") {
            const std::size_t address_at = skip_space(line, e);
            const std::size_t address_end = token_end(line, address_at);
            unsigned address = 0;
            const std::string_view digits = line.substr(address_at, address_end - address_at);
            const auto [end, ec] =
                std::from_chars(digits.data(), digits.data() + digits.size(), address);
            const std::string_view name = rest(address_end);
            if (digits.empty() || ec != std::errc{} || end != digits.data() + digits.size() ||
                address > 255 || name.empty()) {
                return error_at(address_at,
                                "\"# device\" needs a slave address (0-255) and a profile name, "
                                "e.g. \"# device 3 pdu485\"");
            }
            info_.devices.emplace_back(static_cast<std::uint8_t>(address), std::string(name));
        } else if (word == "profile") {
            const std::string_view name = rest(e);
            if (name.empty()) return error_at(e, "\"# profile\" needs the profile's name");
            embedding_ = &info_.embedded_profiles.emplace_back(std::string(name), "").second;
        } else if (word == "end" && rest(e) == "profile") {
            embedding_ = nullptr;
        }
        return true;
    }

    // False on a bad line, its error kept in failed_: a Result would be built, moved and
    // checked for every good line.
    bool data_line(std::string_view line, Chunk& out) {
        std::size_t i = skip_space(line, 0);
        Nanos time = 0;
        std::size_t stamp_length = 0;
        const TimeParse parsed = parse_seconds(line.substr(i), time, stamp_length);
        std::size_t e = i + stamp_length;
        const std::string_view stamp = parsed == TimeParse::ok
                                           ? line.substr(i, stamp_length)
                                           : line.substr(i, token_end(line, i) - i);
        switch (parsed) {
            case TimeParse::ok:
                break;
            case TimeParse::bad:
                return fail(error_at(i, fmt::format("bad timestamp {} (expected seconds, e.g. "
                                                    "1763798400.022360)",
                                                    quote_token(stamp))));
            case TimeParse::too_precise:
                return fail(
                    error_at(i, fmt::format("timestamp {} has more than 9 fractional digits",
                                            quote_token(stamp))));
            case TimeParse::out_of_range:
                return fail(
                    error_at(i, fmt::format("timestamp {} out of range", quote_token(stamp))));
        }
        out.time = time;
        out.source_line = in_->line_number();
        out.channel.clear();

        i = skip_space(line, e);
        if (i < line.size() && line[i] == '@') {
            e = token_end(line, i);
            if (e == i + 1) {
                out.bytes.clear();
                return fail(error_at(i, "empty channel tag \"@\""));
            }
            // A port's name; the framer keeps those of the chunks it holds.
            constexpr std::size_t kMaxChannelChars = 64;
            if (e - i - 1 > kMaxChannelChars) {
                out.bytes.clear();
                return fail(
                    error_at(i, fmt::format("channel tag {} longer than {} characters",
                                            quote_token(line.substr(i, e - i)), kMaxChannelChars)));
            }
            out.channel.assign(line.substr(i + 1, e - i - 1));
            i = skip_space(line, e);
        }
        if (i == line.size()) {
            out.bytes.clear();
            return fail(error_at(e, "no bytes after the timestamp"));
        }
        // Every byte takes two digits and a separator (none after the last): this bounds
        // the count. The bytes of the last line are kept and only what is missing is
        // added: growing a vector zeroes the new part, and clearing first would make that a
        // memset of the whole bound on every line. The loops work on local pointers:
        // stores through a uint8_t pointer may alias anything, and would make the compiler
        // reload the line's bounds every byte.
        const std::size_t most_bytes = (line.size() - i + 1) / 3;
        if (out.bytes.size() < most_bytes) out.bytes.resize(most_bytes);
        std::uint8_t* const first = out.bytes.data();
        std::uint8_t* next = first;
        const char* p = line.data() + i;
        const char* const end = line.data() + line.size();
        // The usual "XX XX ... XX" with no bounds check but the loops': eight bytes at a
        // time (one check of their digits, one of their separators), then one at a time.
        // The last loop checks every byte's bounds and separators, and costs more than the
        // digits. It takes over at the first byte these do not take (another separator,
        // a bad digit, the last byte), after the spaces it would have skipped.
        while (end - p >= 24) {
            if (((load_word(p) | load_word(p + 8) | load_word(p + 16)) & 0x8080808080808080U) !=
                0) {
                break;
            }
            const std::int64_t low = four_hex_bytes(p);
            const std::int64_t high = four_hex_bytes(p + 12);
            const std::uint64_t separators =
                ((load_word(p) & kSeparators0) ^ spaces_under(kSeparators0)) |
                ((load_word(p + 8) & kSeparators1) ^ spaces_under(kSeparators1)) |
                ((load_word(p + 16) & kSeparators2) ^ spaces_under(kSeparators2));
            if ((low | high) < 0 || separators != 0) break;
            const std::uint64_t eight =
                static_cast<std::uint64_t>(low) | static_cast<std::uint64_t>(high) << 32;
            for (int k = 0; k < 8; ++k) next[k] = static_cast<std::uint8_t>(eight >> (8 * k));
            next += 8;
            p += 24;
        }
        while (end - p >= 3) {
            const std::int64_t byte = hex_pair(p);
            if (byte < 0 || p[2] != ' ') break;
            *next++ = static_cast<std::uint8_t>(byte);
            p += 3;
        }
        while (p < end && is_space(*p)) ++p;
        while (p < end) {
            const std::int64_t byte = p + 1 < end ? hex_pair(p) : -1;
            if (byte < 0 || (p + 2 < end && !is_space(p[2]))) {
                i = static_cast<std::size_t>(p - line.data());
                e = token_end(line, i);
                out.bytes.resize(static_cast<std::size_t>(next - first));
                return fail(error_at(
                    i, fmt::format("bad hex byte {}", quote_token(line.substr(i, e - i)))));
            }
            *next++ = static_cast<std::uint8_t>(byte);
            // Past the byte and the one separator checked above; more are rare.
            p += p + 2 < end ? 3 : 2;
            while (p < end && is_space(*p)) ++p;
        }
        out.bytes.resize(static_cast<std::size_t>(next - first));
        return true;
    }

    std::unique_ptr<InputBuffer> in_;
    SourceInfo info_;
    std::string_view pending_;
    bool has_pending_ = false;
    bool at_end_ = false;
    bool in_header_ = true;             // before the first data line
    bool stopped_here_ = false;         // the last line was `# stopped`
    std::vector<std::string> gaps_;     // the `# gap` lines, as remarks
    std::string* embedding_ = nullptr;  // the profile text `#|` lines go to, in the header
    std::optional<Error> failed_;       // errors stick: the reader cannot tell where to go on
};

}  // namespace

Result<std::unique_ptr<ChunkSource>> make_capture_reader(std::unique_ptr<InputBuffer> in) {
    auto reader = std::make_unique<CaptureReader>(std::move(in));
    Status status = reader->open();
    if (!status) return status.error();
    return std::unique_ptr<ChunkSource>(std::move(reader));
}

}  // namespace rtuscope::detail
