// Hex reader: bytes in hex, a line at a time, the way vendor manuals, serial terminals and
// the debug output of Modbus libraries and firmware show them, e.g.
//
//   主机：01 03 00 00 00 02 c4 0b
//   [2024-05-01 10:21:33.120] TX: 01 03 00 00 00 02 C4 0B
//   [01][03][00][00][00][02][C4][0B]                        libmodbus, sent
//   <01><03><04><00><00><00><00><FA><33>                    libmodbus, received
//   [20:22:02][D][uart_debug:114]: >>> 06:03:00:00:00:02:C5:BC
//   Modbus write: 06.03.00.00.00.02.C5.BC (8) at 305852
//   2024-05-01T10:21:33.120Z TX <Buffer 06 03 00 00 00 02 c5 bc>
//   | 0000: 06 03 00 00 00 02 C5 BC                         |........|
//   010300000002C40B
//
// Each line is read from a copy in which what cannot be bytes is blanked out first: colour
// escapes, the timestamp (kept as the line's time), byte counts (`(8)`, `8 bytes`, asyn's
// `read 9`) and a hexdump's offset and ASCII column. The line's bytes are then the longest
// run of byte tokens written one way (pairs between spaces, `[xx]`, `<xx>`, `0x..`, `xxH`,
// pairs joined by `-`, `:` or `.`, one continuous even-length token), and the text before
// them is searched for a direction (TX/RX, send/recv, >>>/<<<, master/slave ...), which
// becomes the chunk's channel (docs/formats.md, "Hex logs", says which way).
//
// A line that is one frame by length and CRC is taken as it is; any other (a piece of a
// frame, as a terminal that logs each read() writes it, several frames, a wrong CRC) goes
// to the framer as bytes of the stream. A line without bytes but with a time or a direction
// (asyn's `... /dev/ttyS0 write 8`, a hexdump's `TX (8 bytes)`) is a header: the lines of
// bytes that follow it without either take them.
//
// The first lines of the log (a window of kWindowLines lines with bytes) are read before
// any is handed on, to learn the log's conventions: whether the program that wrote it is
// the master (what it sent are requests) and whether every frame carries a direction.
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <utility>

#include "framing/crc.hpp"
#include "framing/frame.hpp"
#include "input/readers.hpp"

namespace rtuscope::detail {
namespace {

// A line needs this many bytes to be taken, or a timestamp or a direction: a terminal that
// logs each read() marks every line, one byte long or not, while a manual's prose
// ("step 2", "see 10") has neither.
constexpr std::size_t kMinFrameBytes = 3;

// The window the log's conventions are learnt from: this many lines with bytes, or this
// many lines or bytes in all, whichever comes first. Bounded so that a log of any length
// holds at most this much at once.
constexpr std::size_t kWindowLines = 256;
constexpr std::size_t kWindowAllLines = 4096;
constexpr std::size_t kWindowBytes = std::size_t{1} << 20;

bool is_ascii_space(char c) {
    return c == ' ' || c == '\t' || c == '\v' || c == '\f';
}
bool is_digit(char c) {
    return c >= '0' && c <= '9';
}
bool is_letter(char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z');
}
bool is_alnum(char c) {
    return is_digit(c) || is_letter(c);
}
bool is_hex(char c) {
    return hex_value(c) >= 0;
}
char to_lower(char c) {
    return c >= 'A' && c <= 'Z' ? static_cast<char>(c - 'A' + 'a') : c;
}

// Separators between tokens besides white space: commas of C arrays, braces and
// parentheses around them, `**` emphasis and backticks of markdown, table bars, quotes.
bool is_separator(char c) {
    switch (c) {
        case ' ':
        case '\t':
        case '\v':
        case '\f':
        case ',':
        case ';':
        case '*':
        case '`':
        case '|':
        case '"':
        case '\'':
        case '(':
        case ')':
        case '{':
        case '}':
            return true;
        default:
            return false;
    }
}

// Punctuation that may close a run glued to its last byte: `0B>` (Node's <Buffer ...>),
// `0B.` at the end of a sentence, a trailing joiner `06-03-`.
bool is_closing_punct(char c) {
    return c == '.' || c == ':' || c == '-' || c == '>' || c == ']' || c == '!' || c == '?' ||
           c == '=';
}

// Wide separators, turned into spaces in the working copy: the full-width forms a CJK log
// uses, and the no-break space copied from web manuals.
constexpr std::array<std::string_view, 5> kWideSeparators = {
    "\xC2\xA0",      // U+00A0 no-break space
    "\xE3\x80\x80",  // U+3000 ideographic space
    "\xE3\x80\x81",  // U+3001 ideographic comma
    "\xEF\xBC\x8C",  // U+FF0C full-width comma
    "\xEF\xBC\x9B",  // U+FF1B full-width semicolon
};

// Characters that may glue a decoration to the first byte (`主机：01`, sscom's `收←◆01`):
// turned into a ':' in the working copy, which glues as `TX:01` does.
constexpr std::array<std::string_view, 7> kWideGlue = {
    "\xEF\xBC\x9A",  // U+FF1A full-width colon
    "\xEF\xBC\x9E",  // U+FF1E full-width greater-than
    "\xE3\x80\x91",  // U+3011 right black lenticular bracket
    "\xE2\x86\x90",  // U+2190 leftwards arrow
    "\xE2\x86\x92",  // U+2192 rightwards arrow
    "\xE2\x97\x86",  // U+25C6 black diamond
    "\xE2\x97\x87",  // U+25C7 white diamond
};

// Overwrites s[from, to) with spaces: what cannot be bytes leaves the working copy, and
// every column stays where it was in the line.
void blank(std::string& s, std::size_t from, std::size_t to) {
    std::fill(s.begin() + static_cast<std::ptrdiff_t>(from),
              s.begin() + static_cast<std::ptrdiff_t>(std::min(to, s.size())), ' ');
}

// Colour escapes (ESC [ ... letter, as ESPHome's logger writes them) and other control
// characters become spaces; wide separators too, and wide glue becomes ':'.
void normalize(std::string& s) {
    for (std::size_t i = 0; i < s.size();) {
        const auto c = static_cast<unsigned char>(s[i]);
        if (c == 0x1B) {
            std::size_t j = i + 1;
            if (j < s.size() && s[j] == '[') {
                ++j;
                while (j < s.size() && (is_digit(s[j]) || s[j] == ';' || s[j] == '?')) ++j;
                if (j < s.size() && s[j] >= 0x40 && s[j] <= 0x7E) ++j;
            }
            blank(s, i, j);
            i = j;
            continue;
        }
        if (c < 0x20 || c == 0x7F) {
            s[i++] = ' ';
            continue;
        }
        if (c < 0x80) {
            ++i;
            continue;
        }
        std::size_t replaced = 0;
        for (std::string_view sep : kWideSeparators) {
            if (std::string_view(s).substr(i, sep.size()) == sep) {
                blank(s, i, i + sep.size());
                replaced = sep.size();
                break;
            }
        }
        for (std::size_t k = 0; replaced == 0 && k < kWideGlue.size(); ++k) {
            const std::string_view glue = kWideGlue[k];
            if (std::string_view(s).substr(i, glue.size()) == glue) {
                blank(s, i, i + glue.size() - 1);
                s[i + glue.size() - 1] = ':';
                replaced = glue.size();
            }
        }
        i += replaced != 0 ? replaced : 1;
    }
}

// --- timestamps -----------------------------------------------------------------------

bool digits_at(std::string_view s, std::size_t i, std::size_t n, unsigned& value) {
    if (i + n > s.size()) return false;
    value = 0;
    for (std::size_t k = i; k < i + n; ++k) {
        if (!is_digit(s[k])) return false;
        value = value * 10 + static_cast<unsigned>(s[k] - '0');
    }
    return true;
}

// The digits after a time's seconds, as a fraction of a second.
Nanos fraction_at(std::string_view s, std::size_t& i) {
    Nanos fraction = 0;
    Nanos scale = kNanosPerSecond;
    for (; i < s.size() && is_digit(s[i]); ++i) {
        scale /= 10;  // digits past nanoseconds add nothing
        fraction += (s[i] - '0') * scale;
    }
    return fraction;
}

// `H:MM:SS` or `HH:MM:SS`, then optionally `.frac`, `,frac` or `:mmm`; nanoseconds since
// midnight. A time inside a chain of colon-joined pairs (`06:03:00:00:00:02`, ESPHome's
// bytes) is none.
bool time_of_day_at(std::string_view s, std::size_t i, Nanos& out, std::size_t& end) {
    if (i >= 2 && s[i - 1] == ':' && is_hex(s[i - 2])) return false;
    unsigned h = 0;
    unsigned m = 0;
    unsigned sec = 0;
    std::size_t hour_digits = 2;
    if (!digits_at(s, i, 2, h)) {
        if (!digits_at(s, i, 1, h)) return false;
        hour_digits = 1;
    }
    i += hour_digits;
    if (i >= s.size() || s[i] != ':' || !digits_at(s, i + 1, 2, m)) return false;
    i += 3;
    if (i >= s.size() || s[i] != ':' || !digits_at(s, i + 1, 2, sec)) return false;
    i += 3;
    if (h > 23 || m > 59 || sec > 60) return false;
    Nanos fraction = 0;
    if (i + 1 < s.size() && (s[i] == '.' || s[i] == ',') && is_digit(s[i + 1])) {
        ++i;
        fraction = fraction_at(s, i);
    } else if (i + 1 < s.size() && s[i] == ':' && is_digit(s[i + 1])) {
        // `10:21:33:120`, milliseconds after a colon, as some master tools write them;
        // more colon-joined pairs after it make a chain of bytes instead.
        std::size_t j = i + 1;
        while (j < s.size() && is_digit(s[j])) ++j;
        if (j - i - 1 > 3 || (j < s.size() && (s[j] == ':' || is_alnum(s[j])))) return false;
        ++i;
        fraction = fraction_at(s, i);
    } else if (i < s.size() && is_digit(s[i])) {
        return false;
    }
    if (i + 1 < s.size() && s[i] == ':' && is_hex(s[i + 1])) return false;
    out = ((static_cast<Nanos>(h) * 60 + m) * 60 + sec) * kNanosPerSecond + fraction;
    end = i;
    return true;
}

// `Z`, `+08:00`, `+0800` right after the time: the offset east of UTC, in nanoseconds, and
// where it ends; nullopt when there is none.
std::optional<Nanos> utc_offset_at(std::string_view s, std::size_t i, std::size_t& end) {
    if (i < s.size() && s[i] == 'Z' && (i + 1 == s.size() || !is_letter(s[i + 1]))) {
        end = i + 1;
        return 0;
    }
    if (i >= s.size() || (s[i] != '+' && s[i] != '-')) return std::nullopt;
    unsigned h = 0;
    unsigned m = 0;
    if (!digits_at(s, i + 1, 2, h)) return std::nullopt;
    std::size_t j = i + 3;
    if (j < s.size() && s[j] == ':') ++j;
    if (!digits_at(s, j, 2, m) || h > 14 || m > 59) return std::nullopt;
    if (j + 2 < s.size() && is_digit(s[j + 2])) return std::nullopt;
    end = j + 2;
    const Nanos offset = (static_cast<Nanos>(h) * 60 + m) * 60 * kNanosPerSecond;
    return s[i] == '-' ? -offset : offset;
}

struct FoundTime {
    Nanos time = kNoTime;
    TimeBase base = TimeBase::none;  // unix_time, wall_clock or time_of_day
    std::size_t begin = 0;           // where it is in the line
    std::size_t end = 0;
};

// The date at s[i]: `YYYY-MM-DD` or `YYYY/MM/DD` (then a space, `T` or `_`), or
// `DD.MM.YYYY` (then a space); where its time starts.
bool date_at(std::string_view s, std::size_t i, unsigned& y, unsigned& mo, unsigned& d,
             std::size_t& time_begin) {
    if (i + 11 > s.size()) return false;
    if (digits_at(s, i, 4, y)) {
        const char sep = s[i + 4];
        if ((sep != '-' && sep != '/') || s[i + 7] != sep) return false;
        if (!digits_at(s, i + 5, 2, mo) || !digits_at(s, i + 8, 2, d)) return false;
        const char between = s[i + 10];
        if (between != ' ' && between != 'T' && between != '_') return false;
    } else {
        if (!digits_at(s, i, 2, d) || s[i + 2] != '.' || !digits_at(s, i + 3, 2, mo) ||
            s[i + 5] != '.' || !digits_at(s, i + 6, 4, y) || s[i + 10] != ' ') {
            return false;
        }
    }
    time_begin = i + 11;
    // Times are bounded by kMaxTime (up to the year 2112, see time.hpp); a date outside
    // is no timestamp this reader can keep, and a far later one would overflow.
    return mo >= 1 && mo <= 12 && d >= 1 && d <= 31 && y >= 1900 && y <= 2111;
}

// A date and time at s[i]: Unix time with a UTC offset after it, else the date and time as
// read, counted as if UTC.
bool date_time_at(std::string_view s, std::size_t i, FoundTime& found) {
    unsigned y = 0;
    unsigned mo = 0;
    unsigned d = 0;
    std::size_t time_begin = 0;
    if (!date_at(s, i, y, mo, d, time_begin)) return false;
    Nanos tod = 0;
    std::size_t end = 0;
    if (!time_of_day_at(s, time_begin, tod, end)) return false;
    const std::int64_t days = days_from_civil(y, mo, d);
    std::size_t offset_end = end;
    const std::optional<Nanos> offset = utc_offset_at(s, end, offset_end);
    found.time = days * kNanosPerDay + tod - offset.value_or(0);
    found.base = offset ? TimeBase::unix_time : TimeBase::wall_clock;
    found.begin = i;
    found.end = offset_end;
    return true;
}

// The line's first timestamp, with or without a date.
FoundTime find_time(std::string_view s) {
    for (std::size_t i = 0; i < s.size(); ++i) {
        if (!is_digit(s[i]) || (i > 0 && is_digit(s[i - 1]))) continue;
        FoundTime found;
        if (date_time_at(s, i, found)) return found;
        Nanos t = 0;
        std::size_t end = 0;
        if (time_of_day_at(s, i, t, end)) return {t, TimeBase::time_of_day, i, end};
    }
    return {};
}

// --- directions -----------------------------------------------------------------------

// Which way a line's bytes went, as its text says: seen from the program that wrote the
// log (sent, received), or named outright (master, slave).
enum class Direction : std::uint8_t { none, sent, received, master, slave };

struct DirectionWord {
    std::string_view word;  // lower case
    Direction direction;
    // Verbs and nouns of prose count only as a label, `write:` or `Response:` (not
    // "Read Holding Registers", "no answer from 10").
    bool needs_colon;
};

constexpr auto kDirectionWords = std::to_array<DirectionWord>({
    {"tx", Direction::sent, false},
    {"send", Direction::sent, false},
    {"sent", Direction::sent, false},
    {"sending", Direction::sent, false},
    {"snd", Direction::sent, false},
    {"transmit", Direction::sent, false},
    {"transmitted", Direction::sent, false},
    {"writing", Direction::sent, false},
    {"write", Direction::sent, true},
    {"wrote", Direction::sent, true},
    {"rx", Direction::received, false},
    {"recv", Direction::received, false},
    {"rcv", Direction::received, false},
    {"rcvd", Direction::received, false},
    {"receive", Direction::received, false},
    {"received", Direction::received, false},
    {"receiving", Direction::received, false},
    {"read", Direction::received, true},
    {"master", Direction::master, true},
    {"request", Direction::master, true},
    {"req", Direction::master, true},
    {"query", Direction::master, true},
    {"slave", Direction::slave, true},
    {"response", Direction::slave, true},
    {"resp", Direction::slave, true},
    {"reply", Direction::slave, true},
    {"answer", Direction::slave, true},
});

struct DirectionMark {
    std::string_view mark;
    Direction direction;
};

// Arrows, matched as a whole run of `<`, `>`, `-` and `=`.
constexpr auto kArrows = std::to_array<DirectionMark>({
    {">>>", Direction::sent},
    {">>", Direction::sent},
    {"->", Direction::sent},
    {"-->", Direction::sent},
    {"=>", Direction::sent},
    {"<<<", Direction::received},
    {"<<", Direction::received},
    {"<-", Direction::received},
    {"<--", Direction::received},
    {"<=", Direction::received},
});

// CJK words and arrows, matched anywhere (CJK text has no spaces); longer ones first.
constexpr auto kWideMarks = std::to_array<DirectionMark>({
    {"发送", Direction::sent},
    {"接收", Direction::received},
    {"主机", Direction::master},
    {"主站", Direction::master},
    {"请求", Direction::master},
    {"从机", Direction::slave},
    {"从站", Direction::slave},
    {"应答", Direction::slave},
    {"响应", Direction::slave},
    {"返回", Direction::slave},
    {"发", Direction::sent},
    {"收", Direction::received},
    {"\xE2\x86\x92", Direction::sent},      // U+2192 rightwards arrow
    {"\xE2\x86\x90", Direction::received},  // U+2190 leftwards arrow
});

bool is_arrow_char(char c) {
    return c == '<' || c == '>' || c == '-' || c == '=';
}

// The first direction word, arrow or mark in `s`.
Direction find_direction(std::string_view s) {
    for (std::size_t i = 0; i < s.size(); ++i) {
        const char c = s[i];
        if (is_letter(c) && (i == 0 || !is_alnum(s[i - 1]))) {
            std::size_t e = i;
            while (e < s.size() && is_letter(s[e])) ++e;
            if (e < s.size() && is_digit(s[e])) {
                i = e;
                continue;
            }
            constexpr std::size_t kLongest = 12;
            if (e - i <= kLongest) {
                std::array<char, kLongest> lower{};
                for (std::size_t k = i; k < e; ++k) lower[k - i] = to_lower(s[k]);
                const std::string_view word(lower.data(), e - i);
                for (const DirectionWord& w : kDirectionWords) {
                    if (w.word != word) continue;
                    if (!w.needs_colon || (e < s.size() && s[e] == ':')) return w.direction;
                    break;
                }
            }
            i = e - 1;
            continue;
        }
        if (is_arrow_char(c) && (i == 0 || !is_arrow_char(s[i - 1]))) {
            std::size_t e = i;
            while (e < s.size() && is_arrow_char(s[e])) ++e;
            const std::string_view run = s.substr(i, e - i);
            for (const DirectionMark& arrow : kArrows) {
                if (arrow.mark == run) return arrow.direction;
            }
            i = e - 1;
            continue;
        }
        if (static_cast<unsigned char>(c) >= 0x80) {
            for (const DirectionMark& mark : kWideMarks) {
                if (s.substr(i, mark.mark.size()) == mark.mark) {
                    return mark.direction;
                }
            }
        }
    }
    return Direction::none;
}

// --- byte counts and hexdumps ------------------------------------------------------------

bool word_at(std::string_view s, std::size_t i, std::string_view lower_word) {
    if (i + lower_word.size() > s.size()) return false;
    for (std::size_t k = 0; k < lower_word.size(); ++k) {
        if (to_lower(s[i + k]) != lower_word[k]) return false;
    }
    const std::size_t e = i + lower_word.size();
    return e == s.size() || !is_alnum(s[e]);
}

std::size_t skip_spaces(std::string_view s, std::size_t i) {
    while (i < s.size() && is_ascii_space(s[i])) ++i;
    return i;
}

// Blanks the byte counts a line may carry beside its bytes, which would otherwise pass
// for bytes: `(8)`, `(8 bytes)`, `8 bytes`, `12 more bytes`, `len=8`, and the count after
// asyn's `read`/`write`/`wrote` at the end of the line. Returns the direction such a verb
// gives.
Direction strip_counts(std::string& s) {
    const std::string_view v(s);
    Direction verb = Direction::none;
    for (std::size_t i = 0; i < v.size(); ++i) {
        if (!is_digit(v[i]) || (i > 0 && is_alnum(v[i - 1]))) continue;
        std::size_t e = i;
        while (e < v.size() && is_digit(v[e])) ++e;
        if (e < v.size() && (is_letter(v[e]) || v[e] == '.' || v[e] == ':' || v[e] == '-')) {
            // A number glued to something else (`12ms`, `3.5`, a time, a date) counts nothing.
            i = e;
            continue;
        }
        std::size_t after = skip_spaces(v, e);
        if (word_at(v, after, "more")) after = skip_spaces(v, after + 4);
        std::size_t end = e;
        if (word_at(v, after, "bytes")) {
            end = after + 5;
        } else if (word_at(v, after, "byte")) {
            end = after + 4;
        }
        std::size_t before = i;
        while (before > 0 && is_ascii_space(v[before - 1])) --before;
        const bool in_parens = before > 0 && v[before - 1] == '(' &&
                               skip_spaces(v, end) < v.size() && v[skip_spaces(v, end)] == ')';
        bool labelled = false;
        for (const std::string_view label : {"len", "length"}) {
            std::size_t k = before;
            while (k > 0 && (v[k - 1] == '=' || v[k - 1] == ':' || is_ascii_space(v[k - 1]))) --k;
            if (k != before && k >= label.size() && word_at(v, k - label.size(), label) &&
                (k == label.size() || !is_alnum(v[k - label.size() - 1]))) {
                labelled = true;
            }
        }
        bool verb_count = false;
        if (skip_spaces(v, e) == v.size() && before < i) {
            for (const auto& [word, direction] :
                 {std::pair{std::string_view("read"), Direction::received},
                  std::pair{std::string_view("write"), Direction::sent},
                  std::pair{std::string_view("wrote"), Direction::sent}}) {
                if (before >= word.size() && word_at(v, before - word.size(), word) &&
                    (before == word.size() || !is_alnum(v[before - word.size() - 1]))) {
                    verb_count = true;
                    verb = direction;
                }
            }
        }
        if (end != e || in_parens || labelled || verb_count) blank(s, i, end);
        i = end;
    }
    return verb;
}

// The character a hexdump's ASCII column shows for a byte: itself if printable, else '.'.
bool shows_as(char column, std::uint8_t byte) {
    if (column == '.') return true;  // some dumps print '.' for every byte
    return byte >= 0x20 && byte < 0x7F && column == static_cast<char>(byte);
}

// The two-digit tokens just before `at`, last first, at most `want` of them.
std::size_t pairs_before(std::string_view s, std::size_t at, std::size_t want,
                         std::array<std::uint8_t, 64>& bytes) {
    std::size_t n = 0;
    std::size_t i = at;
    // A dump pads a short last row by three spaces a missing byte; more is no dump's row.
    constexpr std::size_t kMaxPadding = 3 * 64 + 8;
    while (n < want) {
        const std::size_t token_end = i;
        while (i > 0 && token_end - i < kMaxPadding && is_ascii_space(s[i - 1])) --i;
        if (i < 2 || !is_hex(s[i - 1]) || !is_hex(s[i - 2])) break;
        if (i >= 3 && !is_ascii_space(s[i - 3])) break;
        bytes[n++] = static_cast<std::uint8_t>(hex_value(s[i - 2]) << 4 | hex_value(s[i - 1]));
        i -= 2;
    }
    return n;
}

// Blanks a hexdump's offset (`0000:`, `00000010:`, or hexdump -C's 8 digits and two spaces
// at the start of the line) and its ASCII column (`|........|`, or unbarred after an
// offset), which would otherwise pass for bytes.
void strip_hexdump(std::string& s) {
    const std::string_view v(s);
    std::size_t offset_end = 0;
    // The offset: a token of 4, 6 or 8 hex digits and a ':' (`| 0000: 06 03`), or
    // hexdump -C's 8 digits and two spaces first on the line.
    bool first_token = true;
    for (std::size_t i = 0; i < v.size();) {
        if (is_separator(v[i])) {
            ++i;
            continue;
        }
        std::size_t e = i;
        while (e < v.size() && is_hex(v[e])) ++e;
        const std::size_t digits = e - i;
        const bool colon = e + 1 < v.size() && v[e] == ':' && v[e + 1] == ' ';
        const bool dash_c = first_token && digits == 8 && e + 2 < v.size() && v[e] == ' ' &&
                            v[e + 1] == ' ' && skip_spaces(v, e) < v.size() &&
                            is_hex(v[skip_spaces(v, e)]);
        if (digits >= 4 && digits <= 8 && digits % 2 == 0 && (colon || dash_c)) {
            offset_end = colon ? e + 1 : e;
            blank(s, i, offset_end);
            break;
        }
        first_token = false;
        while (e < v.size() && !is_separator(v[e])) ++e;
        i = e;
    }
    // A barred column: the text between the last two '|' shows the bytes before them.
    std::size_t last = v.size();
    while (last > 0 && is_ascii_space(v[last - 1])) --last;
    constexpr std::size_t kMaxColumn = 64;
    std::array<std::uint8_t, 64> bytes{};
    if (last > 0 && v[last - 1] == '|') {
        const std::size_t close = last - 1;
        for (std::size_t open = close; open-- > 0 && close - open <= kMaxColumn + 1;) {
            if (v[open] != '|') continue;
            const std::size_t width = close - open - 1;
            if (width == 0 || pairs_before(v, open, width, bytes) != width) continue;
            bool shown = true;
            for (std::size_t k = 0; k < width && shown; ++k) {
                shown = shows_as(v[close - 1 - k], bytes[k]);
            }
            if (shown) {
                blank(s, open, last);
                return;
            }
        }
    }
    if (offset_end == 0) return;
    // An unbarred column after an offset's bytes: the rest of the line shows them.
    std::size_t i = offset_end;
    std::size_t n = 0;
    std::size_t text_end = v.size();
    while (text_end > 0 && is_ascii_space(v[text_end - 1])) --text_end;
    for (;;) {
        const std::size_t t = skip_spaces(v, i);
        if (t + 2 > v.size() || !is_hex(v[t]) || !is_hex(v[t + 1]) ||
            (t + 2 < v.size() && !is_ascii_space(v[t + 2])) || n == kMaxColumn) {
            break;
        }
        bytes[n++] = static_cast<std::uint8_t>(hex_value(v[t]) << 4 | hex_value(v[t + 1]));
        i = t + 2;
        const std::size_t rest = skip_spaces(v, i);
        const std::size_t rest_end = std::max(rest, text_end);
        if (rest_end - rest != n) continue;
        bool shown = true;
        for (std::size_t k = 0; k < n && shown; ++k) shown = shows_as(v[rest + k], bytes[k]);
        if (shown) {
            blank(s, i, v.size());
            return;
        }
    }
}

// --- byte runs --------------------------------------------------------------------------

// The ways a log writes bytes; a run of bytes is written one way throughout.
enum class Style : std::uint8_t {
    none,
    pair,        // 01 03 00
    prefixed,    // 0x01 0x03, 0x1 0x3
    h_suffix,    // 01H 03H (Chinese manuals)
    square,      // [01][03] (libmodbus, sent)
    angle,       // <01><03> (libmodbus, received)
    dashed,      // 01-03-00
    coloned,     // 01:03:00 (ESPHome)
    dotted,      // 01.03.00
    continuous,  // 010300 (one token)
};

bool is_joined(Style style) {
    return style == Style::dashed || style == Style::coloned || style == Style::dotted;
}

// The bytes one token holds, and where their digits are: the k-th byte's digits start at
// first_digit + k * stride.
struct Unit {
    Style style = Style::none;
    std::size_t count = 0;
    std::size_t begin = 0;        // first byte's text (its bracket, its 0x or its first digit)
    std::size_t first_digit = 0;  // first byte's first hex digit
    std::size_t stride = 2;
    bool one_digit = false;  // `0x6`: a byte written with one digit
    bool glued = false;      // a decoration is glued in front (`TX:01`): a run starts here
    bool closed = false;     // punctuation follows (`0B>`): a run ends here
};

// Whether the character before s[at] glues a decoration to a byte there: `TX:01`, `RX>01`,
// `]01` after a bracketed time, `data=01`. A ':' after a digit is inside a time.
bool glue_before(std::string_view s, std::size_t word_begin, std::size_t at) {
    const char c = s[at - 1];
    if (c == ':') return at - 1 == word_begin || !is_digit(s[at - 2]);
    return c == '>' || c == ']' || c == '=';
}

// A token, s[begin, end), as the style readers see it: `text_end` is where punctuation
// that closes it starts (`0B>`), `digits` where the hex digits before that start.
struct Token {
    std::string_view s;
    std::size_t begin = 0;
    std::size_t end = 0;
    std::size_t text_end = 0;
    std::size_t digits = 0;

    [[nodiscard]] bool closed() const { return text_end < end; }
    [[nodiscard]] std::size_t digit_count() const { return text_end - digits; }
};

// What a style's reader makes of a token: not its style (the next reader tries), its style
// but no bytes (`0xCA08`, a number: no reader tries further), or its bytes.
using StyleRead = std::optional<Unit>;
constexpr Unit kNotBytes{};

Unit unit_at(const Token& t, Style style, std::size_t count, std::size_t begin,
             std::size_t first_digit, std::size_t stride) {
    Unit unit;
    unit.style = style;
    unit.count = count;
    unit.begin = begin;
    unit.first_digit = first_digit;
    unit.stride = stride;
    unit.glued = begin > t.begin;
    unit.closed = t.closed();
    return unit;
}

// `[01][03]...` or `<01><03>...`, a decoration before (`TX:[01]`), punctuation after.
template <char Open, char Close, Style S>
StyleRead read_bracketed(const Token& t) {
    const std::string_view s = t.s;
    const auto pair_at = [&](std::size_t k) {
        return k + 3 < t.end && s[k] == Open && is_hex(s[k + 1]) && is_hex(s[k + 2]) &&
               s[k + 3] == Close;
    };
    std::size_t first = t.begin;
    while (first + 3 < t.end && !pair_at(first)) ++first;
    if (!pair_at(first)) return std::nullopt;
    std::size_t p = first;
    std::size_t count = 0;
    for (; pair_at(p); p += 4) ++count;
    for (std::size_t r = p; r < t.end; ++r) {
        if (!is_closing_punct(s[r])) return std::nullopt;
    }
    Unit unit = unit_at(t, S, count, first, first + 1, 4);
    unit.closed = p < t.end;
    return unit;
}

// `01H`, alone or glued (`发送：01H`).
StyleRead read_h_suffixed(const Token& t) {
    const std::string_view s = t.s;
    const std::size_t end = t.text_end;
    if (end - t.begin < 3 || (s[end - 1] != 'H' && s[end - 1] != 'h') || !is_hex(s[end - 2]) ||
        !is_hex(s[end - 3])) {
        return std::nullopt;
    }
    const std::size_t at = end - 3;
    if (at != t.begin && (is_hex(s[at - 1]) || !glue_before(s, t.begin, at))) return kNotBytes;
    return unit_at(t, Style::h_suffix, 1, at, at, 2);
}

// `0x01`, unpadded `0x1`, or a long `0x0103...`; a shorter `0xCA08` is a 16-bit number as
// C prints it, and no bytes: bytes run to a frame's length at least.
StyleRead read_prefixed(const Token& t) {
    const std::string_view s = t.s;
    const std::size_t j = t.digits;
    if (t.digit_count() == 0 || j - t.begin < 2 || (s[j - 1] != 'x' && s[j - 1] != 'X') || s[j - 2] != '0') {
        return std::nullopt;
    }
    const std::size_t at = j - 2;
    if (at > t.begin && !glue_before(s, t.begin, at)) return kNotBytes;
    const std::size_t digits = t.digit_count();
    if (digits <= 2) {
        Unit unit = unit_at(t, Style::prefixed, 1, at, j, 2);
        unit.one_digit = digits == 1;
        return unit;
    }
    constexpr std::size_t kMinPrefixedDigits = 2 * kMinAdu;
    if (digits % 2 != 0 || digits < kMinPrefixedDigits) return kNotBytes;
    return unit_at(t, Style::continuous, digits / 2, at, j, 2);
}

// `06-03-00`, `06:03:00`, `06.03.00`, with a decoration glued in front (`Tx:06:03:00`); what
// comes before the first pair must not be more of a number (`2024-05-01`).
template <char Joiner, Style S>
StyleRead read_joined(const Token& t) {
    const std::string_view s = t.s;
    const std::size_t j = t.digits;
    if (t.digit_count() != 2 || j == t.begin || s[j - 1] != Joiner) return std::nullopt;
    std::size_t first = j;
    std::size_t count = 1;
    while (first >= t.begin + 3 && s[first - 1] == Joiner && is_hex(s[first - 2]) &&
           is_hex(s[first - 3]) && (first - 3 == t.begin || !is_hex(s[first - 4]))) {
        first -= 3;
        ++count;
    }
    if (count < 2) return std::nullopt;
    if (first != t.begin) {
        const bool decorated = s[first - 1] == Joiner
                                   ? first - 1 == t.begin || !is_hex(s[first - 2])
                                   : glue_before(s, t.begin, first);
        if (!decorated) return kNotBytes;
    }
    return unit_at(t, S, count, first, first, 3);
}

// `01` between separators, or one continuous even-length `010300000002C40B`.
StyleRead read_plain(const Token& t) {
    const std::size_t digits = t.digit_count();
    if (digits == 0 || digits % 2 != 0) return kNotBytes;
    if (t.digits > t.begin && !glue_before(t.s, t.begin, t.digits)) return kNotBytes;
    if (digits == 2) return unit_at(t, Style::pair, 1, t.digits, t.digits, 2);
    return unit_at(t, Style::continuous, digits / 2, t.digits, t.digits, 2);
}

struct StyleReader {
    std::string_view example;
    StyleRead (*read)(const Token&);
};

// Each style a log writes bytes in, tried in this order: a token is read by the first
// whose shape it has.
constexpr auto kStyleReaders = std::to_array<StyleReader>({
    {"[01][03]", read_bracketed<'[', ']', Style::square>},
    {"<01><03>", read_bracketed<'<', '>', Style::angle>},
    {"01H 03H", read_h_suffixed},
    {"0x01 0x3, 0x0103...", read_prefixed},
    {"01-03-00", read_joined<'-', Style::dashed>},
    {"01:03:00", read_joined<':', Style::coloned>},
    {"01.03.00", read_joined<'.', Style::dotted>},
    {"01 03, 0103...", read_plain},
});

// What the token s[b, e) holds, if it is bytes.
Unit parse_unit(std::string_view s, std::size_t b, std::size_t e) {
    Token t{s, b, e, e, e};
    while (t.text_end > b && is_closing_punct(s[t.text_end - 1])) --t.text_end;
    t.digits = t.text_end;
    while (t.digits > b && is_hex(s[t.digits - 1])) --t.digits;
    for (const StyleReader& reader : kStyleReaders) {
        if (const StyleRead read = reader.read(t)) return *read;
    }
    return kNotBytes;
}

void append_unit_bytes(std::string_view s, const Unit& unit, std::vector<std::uint8_t>& bytes) {
    for (std::size_t k = 0; k < unit.count; ++k) {
        const std::size_t at = unit.first_digit + k * unit.stride;
        bytes.push_back(unit.one_digit ? static_cast<std::uint8_t>(hex_value(s[at]))
                                       : static_cast<std::uint8_t>(hex_value(s[at]) << 4 |
                                                                   hex_value(s[at + 1])));
    }
}

// Consecutive tokens of one style.
struct Run {
    Style style = Style::none;
    std::size_t count = 0;
    std::size_t begin = 0;       // first byte's text
    std::size_t word_begin = 0;  // the first token's start
    std::size_t end = 0;         // the last token's end
    bool closed = false;
};

bool all_decimal(std::string_view s, const Run& run) {
    for (std::size_t i = run.begin; i < run.end; ++i) {
        if (is_letter(s[i]) && s[i] != 'x' && s[i] != 'X') return false;
    }
    return true;
}

template <class Visit>
void for_each_token(std::string_view s, std::size_t from, std::size_t to, Visit visit) {
    std::size_t i = from;
    while (i < to) {
        if (is_separator(s[i])) {
            ++i;
            continue;
        }
        std::size_t e = i;
        while (e < to && !is_separator(s[e])) ++e;
        visit(i, e);
        i = e;
    }
}

// --- one line ----------------------------------------------------------------------------

// What libmodbus's debug output says of the program that wrote it.
enum class RoleHint : std::uint8_t { none, master, slave };

struct ScannedLine {
    std::size_t byte_count = 0;
    FoundTime time;
    Direction direction = Direction::none;
    RoleHint role = RoleHint::none;
    // No bytes, and no word but direction words: a label for the lines after it (`TX:`,
    // `Master -> Slave:`, `主机发送：`), not prose that happens to hold one.
    bool label = false;
};

bool is_direction_word(std::string_view word) {
    constexpr std::size_t kLongest = 12;
    if (word.size() > kLongest) return false;
    std::array<char, kLongest> lower{};
    for (std::size_t k = 0; k < word.size(); ++k) lower[k] = to_lower(word[k]);
    const std::string_view lowered(lower.data(), word.size());
    return std::any_of(kDirectionWords.begin(), kDirectionWords.end(),
                       [&](const DirectionWord& w) { return w.word == lowered; });
}

// Whether every ASCII word of `s` is a direction word.
bool only_direction_words(std::string_view s) {
    for (std::size_t i = 0; i < s.size(); ++i) {
        if (!is_alnum(s[i])) continue;
        std::size_t e = i;
        while (e < s.size() && is_alnum(s[e])) ++e;
        if (!is_direction_word(s.substr(i, e - i))) return false;
        i = e;
    }
    return true;
}

class LineScanner {
  public:
    // Scans one line, appending its bytes to `bytes`.
    ScannedLine scan(std::string_view line, std::vector<std::uint8_t>& bytes) {
        work_.assign(line);
        normalize(work_);
        ScannedLine out;
        out.time = find_time(work_);
        if (has_time(out.time.time)) blank(work_, out.time.begin, out.time.end);
        verb_direction_ = strip_counts(work_);
        strip_hexdump(work_);
        const std::string_view s(work_);
        const Run run = find_run_before_comment(s, line);
        if (run.count == 0) {
            out.direction = find_direction(line);
            if (out.direction == Direction::none) out.direction = verb_direction_;
            out.label = out.direction != Direction::none && only_direction_words(s);
            if (line.find("Waiting for a confirmation") != std::string_view::npos) {
                out.role = RoleHint::master;
            } else if (line.find("Waiting for an indication") != std::string_view::npos) {
                out.role = RoleHint::slave;
            }
            return out;
        }
        out.byte_count = run.count;
        out.direction = direction_before(line, run.begin);
        // libmodbus prints what it sends as [01][03]..., what it receives as <01><03>...
        if (out.direction == Direction::none && run.style == Style::square) {
            out.direction = Direction::sent;
        }
        if (out.direction == Direction::none && run.style == Style::angle) {
            out.direction = Direction::received;
        }
        for_each_token(s, run.word_begin, run.end, [&](std::size_t b, std::size_t e) {
            append_unit_bytes(s, parse_unit(s, b, e), bytes);
        });
        return out;
    }

  private:
    Direction direction_before(std::string_view line, std::size_t at) const {
        const Direction found = find_direction(line.substr(0, at));
        return found != Direction::none ? found : verb_direction_;
    }

    // A run that numbers often look like: two joined pairs (`12.34`, `10:21`, `12-14`), a
    // decimal token (`at 305852`, `9600`, `Uptime 12345678 ms`) unless it is one whole frame
    // by length and CRC. It counts only right after a direction (`RX: 0103`).
    bool is_weak(std::string_view s, const Run& run) {
        if (is_joined(run.style)) return run.count <= 2;
        if (run.style != Style::continuous || !all_decimal(s, run)) return false;
        if (run.count < kMinAdu) return true;
        decimal_bytes_.clear();
        append_unit_bytes(s, parse_unit(s, run.word_begin, run.end), decimal_bytes_);
        return !is_whole_frame(decimal_bytes_, standard_rules());
    }

    // Whether a direction stands right before the run (`RX: 0103`, `TX:0103`, `<<< 01:03`),
    // rather than anywhere in the line (`Modbus master ready, 9600 baud`).
    static bool marked_just_before(std::string_view s, std::string_view line, const Run& run) {
        std::size_t from = run.word_begin;
        if (from == run.begin) {
            while (from > 0 && is_separator(s[from - 1])) --from;
            while (from > 0 && !is_separator(s[from - 1])) --from;
        }
        return find_direction(line.substr(from, run.begin - from)) != Direction::none;
    }

    // A trailing comment (`#` or `//`) may hold bytes of its own, and a decoration may hold
    // a '#' (`Frame #3: 01 03 ...`), so each comment marker is tried as the end of the
    // bytes in turn, and the first that leaves a frame's worth before it wins; then the
    // whole line. Only the first few markers are tried, so that a line of a thousand '#'
    // costs no more than a few scans.
    Run find_run_before_comment(std::string_view s, std::string_view line) {
        constexpr int kMaxCuts = 8;
        int cuts = 0;
        for (std::size_t i = 0; i < s.size() && cuts < kMaxCuts; ++i) {
            if (s[i] != '#' && s.substr(i, 2) != "//") continue;
            ++cuts;
            const Run cut = find_run(s, i, line);
            if (cut.count >= kMinFrameBytes) return cut;
            if (s[i] == '/') ++i;
        }
        return find_run(s, s.size(), line);
    }

    // The line's bytes in s[0, limit): the longest run of one style (the later of two as
    // long); a continuous token only when no run of separated bytes has two or more; a
    // weak run only on a line that names a direction.
    Run find_run(std::string_view s, std::size_t limit, std::string_view line) {
        Run best_separated;
        Run best_continuous;
        Run current;
        const auto finish = [&] {
            if (current.count == 0) return;
            if (!is_weak(s, current) || marked_just_before(s, line, current)) {
                Run& best = current.style == Style::continuous ? best_continuous : best_separated;
                if (current.count >= best.count) best = current;
            }
            current = Run{};
        };
        for_each_token(s, 0, limit, [&](std::size_t b, std::size_t e) {
            const Unit unit = parse_unit(s, b, e);
            if (unit.style == Style::none) {
                finish();
                return;
            }
            const bool extends = current.count != 0 && unit.style == current.style &&
                                 unit.style != Style::continuous && !unit.glued && !current.closed;
            if (!extends) {
                finish();
                current.style = unit.style;
                current.begin = unit.begin;
                current.word_begin = b;
            }
            current.count += unit.count;
            current.end = e;
            current.closed = unit.closed;
        });
        finish();
        if (best_separated.count >= 2 || best_continuous.count == 0) return best_separated;
        return best_continuous;
    }

    std::string work_;
    std::vector<std::uint8_t> decimal_bytes_;
    Direction verb_direction_ = Direction::none;
};

// How a frame's length and CRC read it: as a request, as an answer, or either.
struct Shape {
    bool request = false;
    bool answer = false;
    std::size_t length = 0;  // of the reading found
};

std::size_t checked_length(const FrameLength& length, std::span<const std::uint8_t> head) {
    if (length.kind != FrameLength::Kind::fixed || length.bytes > head.size() ||
        length.bytes < kMinAdu) {
        return 0;
    }
    return check_crc(head.first(length.bytes)).status == CrcStatus::bad ? 0 : length.bytes;
}

// The frame at the start of `head`, by the standard lengths and the CRC.
Shape shape_at(std::span<const std::uint8_t> head) {
    Shape shape;
    if (head.size() < kMinAdu) return shape;
    const FrameLengths lengths = standard_rules().frame_lengths(head);
    const std::size_t as_request = checked_length(lengths.request, head);
    const std::size_t as_answer = checked_length(lengths.response, head);
    shape.request = as_request != 0;
    shape.answer = as_answer != 0;
    shape.length = as_request != 0 ? as_request : as_answer;
    return shape;
}

// Whether the frames found one after another from the start of `bytes` include one that
// only the other direction can send: a half-duplex adapter's echo of the request before
// the answer, a terminal that did not break the line between them.
bool holds_other_direction(std::span<const std::uint8_t> bytes, bool as_request) {
    for (std::size_t at = 0; at < bytes.size();) {
        const Shape shape = shape_at(bytes.subspan(at));
        if (shape.length == 0) return false;
        if (as_request ? shape.answer && !shape.request : shape.request && !shape.answer) {
            return true;
        }
        at += shape.length;
    }
    return false;
}

// Lines listed in a remark, as ranges of consecutive lines; only the first kKeptRanges.
class LineRanges {
  public:
    void add(int line) {
        ++count_;
        if (!ranges_.empty() && ranges_.back().second == line - 1) {
            ranges_.back().second = line;
        } else if (ranges_.size() < kKeptRanges) {
            ranges_.emplace_back(line, line);
        } else {
            dropped_ = true;
        }
    }
    [[nodiscard]] std::size_t count() const { return count_; }
    [[nodiscard]] std::string text() const {
        constexpr std::size_t kShownRanges = 20;
        std::string out;
        for (std::size_t i = 0; i < ranges_.size() && i < kShownRanges; ++i) {
            if (i > 0) out += ", ";
            const auto [first, last] = ranges_[i];
            out += first == last ? fmt::format("{}", first) : fmt::format("{}-{}", first, last);
        }
        if (ranges_.size() > kShownRanges || dropped_) out += ", ...";
        return out;
    }

  private:
    static constexpr std::size_t kKeptRanges = 1000;
    std::size_t count_ = 0;
    std::vector<std::pair<int, int>> ranges_;  // first and last line of each run
    bool dropped_ = false;
};

// --- the reader -----------------------------------------------------------------------

class HexReader final : public ChunkSource {
  public:
    explicit HexReader(std::unique_ptr<InputBuffer> in) : in_(std::move(in)) {
        info_.name = in_->name();
        info_.format = "hex";
        // A log stamps a line when it saw it: the frame, or the piece of one, starts then.
        info_.chunk_time_is_start = true;
        info_.chunk_is_line = true;
    }

    // Reads the window, so that the log's conventions, info().timed and info().time_base
    // are known before the pipeline copies them. An error in the window comes after the
    // lines before it, as anywhere else.
    void open() {
        std::size_t byte_lines = 0;
        std::size_t bytes = 0;
        while (byte_lines < kWindowLines && held_end_ < kWindowAllLines && bytes < kWindowBytes &&
               !ended_) {
            const std::size_t before = held_end_;
            read_more();
            for (std::size_t i = before; i < held_end_; ++i) {
                if (held_[i].skipped) continue;
                ++byte_lines;
                bytes += held_[i].chunk.bytes.size();
            }
        }
        learn_conventions();
    }

    [[nodiscard]] const SourceInfo& info() const override { return info_; }

    Result<bool> next(Chunk& out) override {
        for (;;) {
            while (held_begin_ == held_end_) {
                held_begin_ = held_end_ = 0;
                if (ended_) {
                    if (error_) return *error_;
                    return false;
                }
                read_more();
            }
            Held& held = held_[held_begin_++];
            if (held.skipped) {
                skipped_.add(held.line);
                continue;
            }
            if (directed_log_ && held.direction == Direction::none && !held.chunk.whole_frame) {
                undirected_.add(held.line);
                continue;
            }
            out.bytes.swap(held.chunk.bytes);
            out.time = held.chunk.time;
            out.source_line = held.line;
            out.whole_frame = held.chunk.whole_frame;
            out.duration = kNoTime;
            out.time_estimated = false;
            out.char_errors.clear();
            out.channel.assign(channel_of(held, out.bytes));
            ++(out.whole_frame ? whole_lines_ : stream_lines_);
            return true;
        }
    }

    [[nodiscard]] std::vector<std::string> remarks() const override {
        std::vector<std::string> out;
        // Said only when some line was not a frame of its own: otherwise every line was
        // one frame, as most logs are.
        if (stream_lines_ != 0) {
            out.push_back(fmt::format(
                "{} held one frame{}, {} line{} framed as a byte stream (not one frame by "
                "length and CRC)",
                whole_lines_ == 0   ? std::string("no line")
                : whole_lines_ == 1 ? std::string("1 line")
                                    : fmt::format("{} lines", whole_lines_),
                whole_lines_ <= 1 ? "" : " each", stream_lines_,
                stream_lines_ == 1 ? " was" : "s were"));
        }
        // Text in which few lines held bytes and few a timestamp (a log stamps most of
        // its lines, those between its frames too): a document, a source file, another
        // tool's output, read as a hex log because it is text. One line says so; the list
        // of the lines it skipped would only list most of the file.
        const std::size_t skipped = skipped_.count();
        if (skipped != 0 && byte_lines_ * 4 < text_lines_ && stamped_lines_ * 2 < text_lines_) {
            const std::string skipped_text =
                fmt::format("{} line{} skipped", skipped, skipped == 1 ? "" : "s");
            out.push_back(byte_lines_ == 0
                              ? fmt::format("no line held bytes in hex: this is not a hex log ({})",
                                            skipped_text)
                              : fmt::format("only {} of {} lines held bytes in hex: this does not "
                                            "look like a hex log ({})",
                                            byte_lines_, text_lines_, skipped_text));
        } else if (skipped != 0) {
            out.push_back(fmt::format("skipped {} line{} with no frame: {}", skipped,
                                      skipped == 1 ? "" : "s", skipped_.text()));
        }
        if (undirected_.count() != 0) {
            out.push_back(fmt::format(
                "skipped {} line{} with bytes but no direction, in a log that gives one with "
                "its frames: {}",
                undirected_.count(), undirected_.count() == 1 ? "" : "s", undirected_.text()));
        }
        return out;
    }

  private:
    struct Held {
        Chunk chunk;  // time, bytes and whole_frame
        int line = 0;
        bool skipped = false;  // a line with no frame
        Direction direction = Direction::none;
    };

    // A line without bytes but with a time or a direction: the lines of bytes after it
    // that have neither take them.
    struct Header {
        bool active = false;
        int line = 0;
        bool used = false;  // a line of bytes took its time or direction
        Nanos time = kNoTime;
        TimeBase base = TimeBase::none;
        Direction direction = Direction::none;
    };

    Held& hold() {
        if (held_end_ == held_.size()) held_.emplace_back();
        return held_[held_end_++];
    }

    void hold_skip(int line) {
        Held& held = hold();
        held.skipped = true;
        held.line = line;
        held.chunk.bytes.clear();
    }

    // The header's line is no frame unless lines of bytes took what it gave.
    void end_header() {
        if (header_.active && !header_.used) hold_skip(header_.line);
        header_ = Header{};
    }

    // Reads lines until one gives something to hand on (a chunk or a skipped line), or
    // the input ends.
    void read_more() {
        const std::size_t before = held_end_;
        while (held_end_ == before && !ended_) read_line();
    }

    void read_line() {
        std::string_view line;
        Result<bool> more = in_->next_line(line);
        if (!more || !*more) {
            end_header();
            if (!more) error_ = more.error();
            ended_ = true;
            return;
        }
        const int number = in_->line_number();
        if (number == 1 && line.starts_with("\xEF\xBB\xBF")) line.remove_prefix(3);
        if (is_blank_or_comment(line)) return;
        scratch_.clear();
        const ScannedLine scanned = scanner_.scan(line, scratch_);
        if (scanned.role != RoleHint::none && role_hint_ == RoleHint::none) {
            role_hint_ = scanned.role;
        }
        const bool timed = has_time(scanned.time.time);
        ++text_lines_;
        if (timed) ++stamped_lines_;
        if (scanned.byte_count == 0) {
            end_header();
            if (timed || scanned.label) {
                header_.active = true;
                header_.line = number;
                header_.time = timed ? line_time(scanned.time) : kNoTime;
                header_.base = scanned.time.base;
                header_.direction = scanned.direction;
            } else {
                hold_skip(number);
            }
            return;
        }
        Nanos time = timed ? line_time(scanned.time) : kNoTime;
        TimeBase base = scanned.time.base;
        Direction direction = scanned.direction;
        // A short line counts when it is marked: its own time or direction, or a header
        // with a time (asyn's), or one whose frame it goes on (a wrapped frame's last line).
        bool marked = timed || direction != Direction::none;
        const bool inherits = !marked && header_.active;
        if (marked) {
            end_header();
        } else if (inherits) {
            // The header's time is when the first line of bytes after it came; the lines
            // that go on (a frame wrapped over several) have it too, and so follow that
            // line's bytes back to back.
            time = header_.time;
            base = header_.base;
            direction = header_.direction;
            marked = has_time(header_.time) || header_.used;
        }
        if (scanned.byte_count < kMinFrameBytes && !marked) {
            hold_skip(number);
            return;
        }
        if (inherits) header_.used = true;
        Held& held = hold();
        held.skipped = false;
        held.line = number;
        held.direction = direction;
        held.chunk.bytes.swap(scratch_);
        held.chunk.time = time;
        // The standard lengths: a device's own layout of a standard code is no
        // frame by them, and its line is framed with the device's rules instead.
        held.chunk.whole_frame = is_whole_frame(held.chunk.bytes, standard_rules());
        ++byte_lines_;
        if (has_time(time)) {
            info_.timed = true;
            // The first timestamp says what the times are.
            if (info_.time_base == TimeBase::none) info_.time_base = base;
        }
    }

    // What the window shows of the log: whether the program that wrote it is the master
    // (libmodbus says so; else the frames it sent are requests more often than answers,
    // or nothing says otherwise), and whether every frame carries a direction (then a line
    // of bytes without one, unless it is one whole frame, is not the bus's: an address, a
    // MAC in a firmware's log).
    void learn_conventions() {
        std::size_t directed = 0;
        std::size_t undirected = 0;
        std::size_t sent_requests = 0;
        std::size_t sent_answers = 0;
        for (std::size_t i = held_begin_; i < held_end_; ++i) {
            const Held& held = held_[i];
            if (held.skipped) continue;
            ++(held.direction == Direction::none ? undirected : directed);
            const bool sent = held.direction == Direction::sent;
            if (!held.chunk.whole_frame || (!sent && held.direction != Direction::received)) {
                continue;
            }
            const Shape shape = shape_at(held.chunk.bytes);
            if (shape.request == shape.answer) continue;
            ++(shape.request == sent ? sent_requests : sent_answers);
        }
        directed_log_ = directed >= 2 && undirected < directed;
        sender_is_master_ = role_hint_ == RoleHint::none ? sent_answers <= sent_requests
                                                         : role_hint_ == RoleHint::master;
    }

    // "master", "slave" or none. A line whose frames go both ways gets none: the framer
    // tells them apart by their shape.
    std::string_view channel_of(const Held& held, std::span<const std::uint8_t> bytes) const {
        bool master = false;
        switch (held.direction) {
            case Direction::none:
                return {};
            case Direction::sent:
                master = sender_is_master_;
                break;
            case Direction::received:
                master = !sender_is_master_;
                break;
            case Direction::master:
                master = true;
                break;
            case Direction::slave:
                master = false;
                break;
        }
        if (holds_other_direction(bytes, master)) return {};
        return master ? "master" : "slave";
    }

    Nanos line_time(const FoundTime& found) {
        if (!has_time(found.time) || found.base != TimeBase::time_of_day) return found.time;
        // A log of times without dates that runs past midnight goes on counting rather
        // than jumping back a day.
        Nanos t = found.time + day_offset_;
        // Never past kMaxTime: a long log flipping between evening and morning would
        // otherwise count days up to an overflow. Stuck there, its time goes back instead.
        if (has_time(last_time_of_day_) && t < last_time_of_day_ - kNanosPerDay / 2 &&
            t <= kMaxTime - kNanosPerDay) {
            day_offset_ += kNanosPerDay;
            t += kNanosPerDay;
        }
        last_time_of_day_ = t;
        return t;
    }

    std::unique_ptr<InputBuffer> in_;
    SourceInfo info_;
    LineScanner scanner_;
    std::vector<std::uint8_t> scratch_;
    // Lines read and not yet handed on: the window at first, then a line or two. Slots are
    // reused, with their byte buffers, so that reading on allocates nothing.
    std::vector<Held> held_;
    std::size_t held_begin_ = 0;
    std::size_t held_end_ = 0;
    bool ended_ = false;
    std::optional<Error> error_;
    Header header_;
    RoleHint role_hint_ = RoleHint::none;
    bool directed_log_ = false;
    bool sender_is_master_ = true;
    Nanos day_offset_ = 0;
    Nanos last_time_of_day_ = kNoTime;
    std::uint64_t whole_lines_ = 0;   // lines handed on that were one frame each
    std::uint64_t stream_lines_ = 0;  // lines handed on as bytes for the framer
    std::size_t byte_lines_ = 0;      // lines with bytes, handed on or not
    std::size_t text_lines_ = 0;      // lines neither blank nor comments
    std::size_t stamped_lines_ = 0;   // lines with a timestamp
    LineRanges skipped_;
    LineRanges undirected_;
};

}  // namespace

bool is_blank_or_comment(std::string_view line) {
    std::size_t i = 0;
    while (i < line.size() && is_ascii_space(line[i])) ++i;
    return i == line.size() || line[i] == '#' || line.substr(i, 2) == "//";
}

Result<std::unique_ptr<ChunkSource>> make_hex_reader(std::unique_ptr<InputBuffer> in) {
    auto reader = std::make_unique<HexReader>(std::move(in));
    reader->open();
    return std::unique_ptr<ChunkSource>(std::move(reader));
}

}  // namespace rtuscope::detail
