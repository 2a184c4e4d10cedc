// Hex reader: bytes in hex, a line at a time, the way vendor manuals and serial-terminal
// logs show them, e.g.
//
//   主机：01 03 00 00 00 02 c4 0b
//   ZB-UVI485模块：**01 03 02 18 18 b2 4e**
//   [2024-05-01 10:21:33.120] TX: 01 03 00 00 00 02 C4 0B
//   10:21:33.120 RX 01 03 02 17 F8 B6 36
//   010300000002C40B                        // one continuous token
//
// The bytes are the longest run of two-digit hex tokens at the end of the line (or one
// continuous even-length token); whatever comes before them is decoration, searched only
// for a timestamp. Most lines hold one frame, and such a line is taken as it is (a whole
// frame); a line that does not (a piece of a frame, as terminals that log each read()
// write them, several frames, a wrong CRC) goes to the framer as bytes of the stream. Scanning from
// the end is what keeps a time like 10:21:33 from being read as bytes: a token with ':' inside is
// never a hex token, and a decoration glued to the first byte (`TX:01`) is only split off when it
// cannot be the tail of a time.
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <memory>
#include <utility>

#include "framing/frame.hpp"
#include "input/readers.hpp"

namespace rtuscope::detail {
namespace {

// A line needs this many bytes to be taken, or a timestamp: a terminal that logs each
// read() stamps every line, while a manual's prose ("step 2", "see 10") has none.
constexpr std::size_t kMinFrameBytes = 3;

bool is_ascii_space(char c) {
    return c == ' ' || c == '\t' || c == '\v' || c == '\f';
}
bool is_digit(char c) {
    return c >= '0' && c <= '9';
}
bool is_letter(char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z');
}

// Separators between tokens besides white space: commas of C arrays, `**` emphasis and
// backticks of markdown, table bars, quotes; and the full-width forms a CJK log uses.
bool is_ascii_separator(char c) {
    return is_ascii_space(c) || c == ',' || c == '*' || c == '`' || c == '|' || c == ';' ||
           c == '"';
}

constexpr std::array<std::string_view, 5> kWideSeparators = {
    "\xC2\xA0",      // U+00A0 no-break space (copied from web manuals)
    "\xE3\x80\x80",  // U+3000 ideographic space
    "\xE3\x80\x81",  // U+3001 ideographic comma
    "\xEF\xBC\x8C",  // U+FF0C full-width comma
    "\xEF\xBC\x9B",  // U+FF1B full-width semicolon
};

// Characters that may glue a decoration to the first byte: `TX:01`, `RX>01`, `主机：01`,
// `[10:21:33]01`, sscom's `收←◆01`, `接收←01`.
constexpr std::array<std::string_view, 7> kWideGlue = {
    "\xEF\xBC\x9A",  // U+FF1A full-width colon
    "\xEF\xBC\x9E",  // U+FF1E full-width greater-than
    "\xE3\x80\x91",  // U+3011 right black lenticular bracket
    "\xE2\x86\x90",  // U+2190 leftwards arrow
    "\xE2\x86\x92",  // U+2192 rightwards arrow
    "\xE2\x97\x86",  // U+25C6 black diamond
    "\xE2\x97\x87",  // U+25C7 white diamond
};

// Length of the separator starting at s[i], 0 if none.
std::size_t separator_at(std::string_view s, std::size_t i) {
    if (is_ascii_separator(s[i])) return 1;
    if (static_cast<unsigned char>(s[i]) < 0x80) return 0;
    for (std::string_view sep : kWideSeparators) {
        if (s.substr(i, sep.size()) == sep) return sep.size();
    }
    return 0;
}

// Length of the separator ending just before s[i], 0 if none.
std::size_t separator_before(std::string_view s, std::size_t i) {
    if (is_ascii_separator(s[i - 1])) return 1;
    if (static_cast<unsigned char>(s[i - 1]) < 0x80) return 0;
    for (std::string_view sep : kWideSeparators) {
        if (i >= sep.size() && s.substr(i - sep.size(), sep.size()) == sep) return sep.size();
    }
    return 0;
}

struct Span {
    std::size_t begin = 0;
    std::size_t end = 0;
};

// The token ending at or before `i`, scanning leftwards; false when there is none.
bool token_before(std::string_view s, std::size_t i, Span& token) {
    for (std::size_t k = 0; i > 0 && (k = separator_before(s, i)) != 0;) i -= k;
    if (i == 0) return false;
    token.end = i;
    while (i > 0 && separator_before(s, i) == 0) --i;
    token.begin = i;
    return true;
}

enum class HexKind : std::uint8_t { none, pair, continuous };

bool all_hex(std::string_view t) {
    return std::all_of(t.begin(), t.end(), [](char c) { return hex_value(c) >= 0; });
}

// `01`, `0x01`, `01H` (Chinese manuals), or an even-length `010300000002C40B`.
HexKind classify(std::string_view t) {
    if (t.size() >= 4 && t[0] == '0' && (t[1] == 'x' || t[1] == 'X')) t.remove_prefix(2);
    if (t.size() == 3 && (t[2] == 'H' || t[2] == 'h')) t.remove_suffix(1);
    if (t.size() < 2 || t.size() % 2 != 0 || !all_hex(t)) return HexKind::none;
    return t.size() == 2 ? HexKind::pair : HexKind::continuous;
}

// Splits `TX:01` into decoration and hex; `hex_begin` is where the hex starts. A ':' after
// a digit is the inside of a time (10:21:33), never a glue.
HexKind classify_glued(std::string_view s, Span token, std::size_t& hex_begin) {
    std::size_t end = token.end;
    const bool h_suffix = end - token.begin >= 3 && (s[end - 1] == 'H' || s[end - 1] == 'h') &&
                          hex_value(s[end - 2]) >= 0 && hex_value(s[end - 3]) >= 0;
    if (h_suffix) --end;
    std::size_t j = end;
    while (j > token.begin && hex_value(s[j - 1]) >= 0) --j;
    if (j == token.begin || j == end) return HexKind::none;
    const char glue = s[j - 1];
    bool glued = false;
    if (glue == ':') {
        glued = j - 1 == token.begin || !is_digit(s[j - 2]);
    } else if (glue == '>' || glue == ']') {
        glued = true;
    } else {
        for (std::string_view g : kWideGlue) {
            if (j - token.begin >= g.size() && s.substr(j - g.size(), g.size()) == g) glued = true;
        }
    }
    if (!glued) return HexKind::none;
    hex_begin = j;
    const std::size_t digits = end - j;
    if (digits == 2) return HexKind::pair;
    return digits % 2 != 0 || h_suffix ? HexKind::none : HexKind::continuous;
}

struct Run {
    std::size_t count = 0;  // bytes
    std::size_t begin = 0;  // where the first byte's hex (or its 0x) starts
};

Run find_run(std::string_view s) {
    Run run;
    Span token;
    if (!token_before(s, s.size(), token)) return run;
    const std::string_view last = s.substr(token.begin, token.end - token.begin);
    std::size_t hex_begin = 0;
    switch (classify(last)) {
        case HexKind::continuous:
            run.count = (last.size() - (last[1] == 'x' || last[1] == 'X' ? 2 : 0)) / 2;
            run.begin = token.begin;
            return run;
        case HexKind::pair:
            break;
        case HexKind::none:
            switch (classify_glued(s, token, hex_begin)) {
                case HexKind::none:
                    return run;
                case HexKind::pair:
                    run.count = 1;
                    run.begin = hex_begin;
                    return run;
                case HexKind::continuous:
                    run.count = (token.end - hex_begin) / 2;
                    run.begin = hex_begin;
                    return run;
            }
            return run;
    }
    run.count = 1;
    run.begin = token.begin;
    while (token_before(s, run.begin, token)) {
        if (classify(s.substr(token.begin, token.end - token.begin)) == HexKind::pair) {
            ++run.count;
            run.begin = token.begin;
            continue;
        }
        if (classify_glued(s, token, hex_begin) == HexKind::pair) {
            ++run.count;
            run.begin = hex_begin;
        }
        break;
    }
    return run;
}

void append_bytes(std::string_view s, std::size_t i, std::vector<std::uint8_t>& bytes) {
    while (i < s.size()) {
        if (const std::size_t k = separator_at(s, i); k != 0) {
            i += k;
            continue;
        }
        std::size_t e = i;
        while (e < s.size() && separator_at(s, e) == 0) ++e;
        std::string_view t = s.substr(i, e - i);
        if (t.size() >= 4 && t[0] == '0' && (t[1] == 'x' || t[1] == 'X')) t.remove_prefix(2);
        // Pairs only: the H of `01H` is left over and dropped.
        for (std::size_t k = 0; k + 1 < t.size(); k += 2) {
            bytes.push_back(static_cast<std::uint8_t>(hex_value(t[k]) << 4 | hex_value(t[k + 1])));
        }
        i = e;
    }
}

// --- timestamps in the decoration ---------------------------------------------------

bool digits_at(std::string_view s, std::size_t i, std::size_t n, unsigned& value) {
    if (i + n > s.size()) return false;
    value = 0;
    for (std::size_t k = i; k < i + n; ++k) {
        if (!is_digit(s[k])) return false;
        value = value * 10 + static_cast<unsigned>(s[k] - '0');
    }
    return true;
}

// `H:MM:SS` or `HH:MM:SS`, then optionally `.frac` or `,frac`; nanoseconds since midnight.
bool time_of_day_at(std::string_view s, std::size_t i, Nanos& out, std::size_t& end) {
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
        Nanos scale = kNanosPerSecond;
        for (; i < s.size() && is_digit(s[i]); ++i) {
            scale /= 10;  // digits past nanoseconds add nothing
            fraction += (s[i] - '0') * scale;
        }
    } else if (i < s.size() && is_digit(s[i])) {
        return false;
    }
    out = ((static_cast<Nanos>(h) * 60 + m) * 60 + sec) * kNanosPerSecond + fraction;
    end = i;
    return true;
}

// `Z`, `+08:00`, `+0800` right after the time: the offset east of UTC, in nanoseconds;
// nullopt when there is none.
std::optional<Nanos> utc_offset_at(std::string_view s, std::size_t i) {
    if (i < s.size() && s[i] == 'Z' && (i + 1 == s.size() || !is_letter(s[i + 1]))) return 0;
    if (i >= s.size() || (s[i] != '+' && s[i] != '-')) return std::nullopt;
    unsigned h = 0;
    unsigned m = 0;
    if (!digits_at(s, i + 1, 2, h)) return std::nullopt;
    std::size_t j = i + 3;
    if (j < s.size() && s[j] == ':') ++j;
    if (!digits_at(s, j, 2, m) || h > 14 || m > 59) return std::nullopt;
    if (j + 2 < s.size() && is_digit(s[j + 2])) return std::nullopt;
    const Nanos offset = (static_cast<Nanos>(h) * 60 + m) * 60 * kNanosPerSecond;
    return s[i] == '-' ? -offset : offset;
}

// `YYYY-MM-DD HH:MM:SS[.frac]` (also `T` or `_` between, `/` in the date): Unix time
// with a UTC offset after it, else the date and time as read, counted as if UTC.
bool date_time_at(std::string_view s, std::size_t i, Nanos& out, bool& zoned) {
    unsigned y = 0;
    unsigned mo = 0;
    unsigned d = 0;
    if (!digits_at(s, i, 4, y) || i + 10 >= s.size()) return false;
    const char sep = s[i + 4];
    if ((sep != '-' && sep != '/') || s[i + 7] != sep) return false;
    if (!digits_at(s, i + 5, 2, mo) || !digits_at(s, i + 8, 2, d)) return false;
    if (mo < 1 || mo > 12 || d < 1 || d > 31) return false;
    // Times are bounded by kMaxTime (up to the year 2112, see time.hpp); a date outside
    // is no timestamp this reader can keep, and a far later one would overflow.
    if (y < 1900 || y > 2111) return false;
    const char between = s[i + 10];
    if (between != ' ' && between != 'T' && between != '_') return false;
    Nanos tod = 0;
    std::size_t end = 0;
    if (!time_of_day_at(s, i + 11, tod, end)) return false;
    const std::int64_t days = days_from_civil(y, mo, d);
    const std::optional<Nanos> offset = utc_offset_at(s, end);
    zoned = offset.has_value();
    out = days * kNanosPerDay + tod - offset.value_or(0);
    return true;
}

struct FoundTime {
    Nanos time = kNoTime;
    TimeBase base = TimeBase::none;  // unix_time, wall_clock or time_of_day
};

FoundTime find_time(std::string_view s) {
    FoundTime time_only;
    for (std::size_t i = 0; i < s.size(); ++i) {
        if (!is_digit(s[i]) || (i > 0 && is_digit(s[i - 1]))) continue;
        Nanos t = 0;
        bool zoned = false;
        if (date_time_at(s, i, t, zoned)) {
            return {t, zoned ? TimeBase::unix_time : TimeBase::wall_clock};
        }
        std::size_t end = 0;
        if (!has_time(time_only.time) && time_of_day_at(s, i, t, end)) {
            time_only = {t, TimeBase::time_of_day};
        }
    }
    return time_only;
}

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

    // Reads up to the first line with bytes so that info().timed and info().time_base
    // are known before the pipeline copies them.
    Status open() {
        Result<bool> got = read_line(pending_);
        if (!got) return got.error();
        has_pending_ = *got;
        return ok_status();
    }

    [[nodiscard]] const SourceInfo& info() const override { return info_; }

    Result<bool> next(Chunk& out) override {
        if (has_pending_) {
            has_pending_ = false;
            out = std::move(pending_);
            return true;
        }
        return read_line(out);
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
        if (skipped_count_ == 0) return out;
        constexpr std::size_t kShownRanges = 20;
        std::string text = fmt::format("skipped {} line{} with no frame: ", skipped_count_,
                                       skipped_count_ == 1 ? "" : "s");
        for (std::size_t i = 0; i < skipped_.size() && i < kShownRanges; ++i) {
            if (i > 0) text += ", ";
            const auto [first, last] = skipped_[i];
            text += first == last ? fmt::format("{}", first) : fmt::format("{}-{}", first, last);
        }
        if (skipped_.size() > kShownRanges || ranges_dropped_) text += ", ...";
        out.push_back(std::move(text));
        return out;
    }

  private:
    Result<bool> read_line(Chunk& out) {
        std::string_view line;
        for (;;) {
            Result<bool> more = in_->next_line(line);
            if (!more || !*more) return more;
            const int number = in_->line_number();
            if (number == 1 && line.starts_with("\xEF\xBB\xBF")) line.remove_prefix(3);
            if (is_blank_or_comment(line)) continue;
            out.bytes.clear();
            const HexLine scanned = scan_hex_line(line, &out.bytes);
            const FoundTime found =
                scanned.byte_count == 0 ? FoundTime{} : find_time(scanned.decoration);
            if (scanned.byte_count < kMinFrameBytes &&
                (scanned.byte_count == 0 || !has_time(found.time))) {
                skip(number);
                continue;
            }
            out.channel.clear();
            out.source_line = number;
            out.time = line_time(found);
            // The standard lengths: a device's own layout of a standard code is no
            // frame by them, and its line is framed with the device's rules instead.
            out.whole_frame = is_whole_frame(out.bytes, standard_rules());
            ++(out.whole_frame ? whole_lines_ : stream_lines_);
            if (has_time(out.time)) {
                info_.timed = true;
                // The first timestamp says what the times are.
                if (info_.time_base == TimeBase::none) info_.time_base = found.base;
            }
            return true;
        }
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

    void skip(int line) {
        ++skipped_count_;
        if (!skipped_.empty() && skipped_.back().second == line - 1) {
            skipped_.back().second = line;
        } else if (skipped_.size() < kKeptRanges) {
            skipped_.emplace_back(line, line);
        } else {
            ranges_dropped_ = true;
        }
    }

    static constexpr std::size_t kKeptRanges = 1000;

    std::unique_ptr<InputBuffer> in_;
    SourceInfo info_;
    Chunk pending_;
    bool has_pending_ = false;
    Nanos day_offset_ = 0;
    Nanos last_time_of_day_ = kNoTime;
    std::uint64_t whole_lines_ = 0;   // lines that were one frame each
    std::uint64_t stream_lines_ = 0;  // lines that went to the framer as bytes
    std::size_t skipped_count_ = 0;
    std::vector<std::pair<int, int>> skipped_;  // first and last line of each run
    bool ranges_dropped_ = false;
};

}  // namespace

bool is_blank_or_comment(std::string_view line) {
    std::size_t i = 0;
    while (i < line.size() && is_ascii_space(line[i])) ++i;
    return i == line.size() || line[i] == '#' || line.substr(i, 2) == "//";
}

// A trailing comment (`#` or `//`) may hold hex of its own, and a decoration may hold a
// '#' (`Frame #3: 01 03 ...`), so each comment marker is tried as the end of the frame in
// turn, and the first that leaves a whole frame before it wins; then the whole line. Only
// the first few markers are tried, so that a line of a thousand '#' costs no more than a
// few scans.
HexLine scan_hex_line(std::string_view line, std::vector<std::uint8_t>* bytes) {
    constexpr int kMaxCuts = 8;
    Run run;
    std::string_view segment = line;
    int cuts = 0;
    for (std::size_t i = 0; i < line.size() && cuts < kMaxCuts; ++i) {
        if (line[i] != '#' && line.substr(i, 2) != "//") continue;
        ++cuts;
        const Run cut = find_run(line.substr(0, i));
        if (cut.count >= kMinFrameBytes) {
            run = cut;
            segment = line.substr(0, i);
            break;
        }
        if (line[i] == '/') ++i;
    }
    if (run.count == 0) run = find_run(line);
    if (bytes != nullptr && run.count != 0) append_bytes(segment, run.begin, *bytes);
    return {run.count, line.substr(0, run.begin)};
}

Result<std::unique_ptr<ChunkSource>> make_hex_reader(std::unique_ptr<InputBuffer> in) {
    auto reader = std::make_unique<HexReader>(std::move(in));
    Status status = reader->open();
    if (!status) return status.error();
    return std::unique_ptr<ChunkSource>(std::move(reader));
}

}  // namespace rtuscope::detail
