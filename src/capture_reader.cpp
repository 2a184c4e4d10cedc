// Capture reader: the native text capture format v1 (DESIGN.md, "Native capture format").
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

#include <cstdint>
#include <limits>
#include <memory>
#include <optional>

#include "readers.hpp"
#include "rtuscope/line_settings.hpp"

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

// The timestamp at the start of `text`, which runs to its end or to a space; `length`
// is set to the timestamp's length. Parsed where it lies: finding the token's end first
// was a pass over every line for nothing.
TimeParse parse_seconds(std::string_view text, Nanos& out, std::size_t& length) {
    constexpr std::int64_t kMaxSeconds = std::numeric_limits<Nanos>::max() / kNanosPerSecond;
    constexpr std::int64_t kMaxFraction = std::numeric_limits<Nanos>::max() % kNanosPerSecond;
    std::size_t i = 0;
    const bool negative = !text.empty() && text[0] == '-';
    if (negative) ++i;
    const std::size_t int_begin = i;
    std::int64_t seconds = 0;
    bool too_big = false;
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
        for (; i < text.size() && is_digit(text[i]); ++i, ++fraction_digits) {
            if (fraction_digits < 9) fraction = fraction * 10 + (text[i] - '0');
        }
        if (fraction_digits == 0) return TimeParse::bad;
    }
    if (i != text.size() && !is_space(text[i])) return TimeParse::bad;
    length = i;
    if (fraction_digits > 9) return TimeParse::too_precise;
    for (std::size_t k = fraction_digits; k < 9; ++k) fraction *= 10;
    if (too_big || seconds > kMaxSeconds || (seconds == kMaxSeconds && fraction > kMaxFraction)) {
        return TimeParse::out_of_range;
    }
    const Nanos value = seconds * kNanosPerSecond + fraction;
    out = negative ? -value : value;
    return TimeParse::ok;
}

class CaptureReader final : public ChunkSource {
  public:
    explicit CaptureReader(std::unique_ptr<InputBuffer> in) : in_(std::move(in)) {
        info_.name = in_->name();
        info_.format = "capture";
        info_.timed = true;
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
                return ok_status();
            }
            Result<bool> comment = comment_line(line);
            if (!comment) return comment.error();
            if (!*comment) {
                pending_ = line;
                has_pending_ = true;
                return ok_status();
            }
        }
    }

    [[nodiscard]] const SourceInfo& info() const override { return info_; }

    Result<bool> next(Chunk& out) override {
        if (failed_) return *failed_;
        if (has_pending_) {
            has_pending_ = false;
            return remember(data_line(pending_, out));
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
            Result<bool> comment = comment_line(line);
            if (!comment) return remember(comment);
            if (!*comment) return remember(data_line(line, out));
        }
    }

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

    Result<bool> remember(Result<bool> result) {
        if (!result) failed_ = result.error();
        return result;
    }

    // True for blank and comment lines (reading `# serial` on the way), false for data.
    Result<bool> comment_line(std::string_view line) {
        std::size_t i = skip_space(line, 0);
        if (i == line.size()) return true;
        if (line[i] != '#') return false;
        i = skip_space(line, i + 1);
        std::size_t e = token_end(line, i);
        if (line.substr(i, e - i) != "serial") return true;

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

    Result<bool> data_line(std::string_view line, Chunk& out) {
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
                return error_at(i, fmt::format("bad timestamp {} (expected seconds, e.g. "
                                               "1763798400.022360)",
                                               quote_token(stamp)));
            case TimeParse::too_precise:
                return error_at(i, fmt::format("timestamp {} has more than 9 fractional digits",
                                               quote_token(stamp)));
            case TimeParse::out_of_range:
                return error_at(i, fmt::format("timestamp {} out of range", quote_token(stamp)));
        }
        out.time = time;
        out.source_line = in_->line_number();
        out.channel.clear();
        out.bytes.clear();

        i = skip_space(line, e);
        if (i < line.size() && line[i] == '@') {
            e = token_end(line, i);
            if (e == i + 1) return error_at(i, "empty channel tag \"@\"");
            out.channel.assign(line.substr(i + 1, e - i - 1));
            i = skip_space(line, e);
        }
        if (i == line.size()) return error_at(e, "no bytes after the timestamp");
        // Every byte takes two digits and a separator (none after the last): this bounds
        // the count. The loop works on local pointers: stores through a uint8_t pointer
        // may alias anything, and made the compiler reload the line's bounds every byte.
        out.bytes.resize((line.size() - i + 1) / 2);
        std::uint8_t* const first = out.bytes.data();
        std::uint8_t* next = first;
        const char* p = line.data() + i;
        const char* const end = line.data() + line.size();
        // The usual "XX XX ... XX" with no bounds check but the loop's: the loop below
        // checks every byte's bounds and separators, and cost more than the digits. It
        // takes over at the first byte this one does not take (another separator, a bad
        // digit, the last byte), after the spaces it would have skipped.
        while (end - p >= 3) {
            const int hi = hex_value(p[0]);
            const int lo = hex_value(p[1]);
            if ((hi | lo) < 0 || p[2] != ' ') break;
            *next++ = static_cast<std::uint8_t>(hi << 4 | lo);
            p += 3;
        }
        while (p < end && is_space(*p)) ++p;
        while (p < end) {
            const int hi = hex_value(p[0]);
            const int lo = p + 1 < end ? hex_value(p[1]) : -1;
            if ((hi | lo) < 0 || (p + 2 < end && !is_space(p[2]))) {
                i = static_cast<std::size_t>(p - line.data());
                e = token_end(line, i);
                out.bytes.resize(static_cast<std::size_t>(next - first));
                return error_at(i,
                                fmt::format("bad hex byte {}", quote_token(line.substr(i, e - i))));
            }
            *next++ = static_cast<std::uint8_t>(hi << 4 | lo);
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
    std::optional<Error> failed_;  // errors stick: the reader cannot tell where to go on
};

}  // namespace

Result<std::unique_ptr<ChunkSource>> make_capture_reader(std::unique_ptr<InputBuffer> in) {
    auto reader = std::make_unique<CaptureReader>(std::move(in));
    Status status = reader->open();
    if (!status) return status.error();
    return std::unique_ptr<ChunkSource>(std::move(reader));
}

}  // namespace rtuscope::detail
