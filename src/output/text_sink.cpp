// Annotated text for people: one line per record, aligned columns, problems marked on
// the line where they happen, a summary at the end.
#include <fmt/color.h>
#include <fmt/format.h>

#include <algorithm>
#include <limits>
#include <optional>
#include <span>

#include "output/block_output.hpp"
#include "output/fields.hpp"
#include "output/record_text.hpp"
#include "output/sinks.hpp"
#include "util/terminal.hpp"
#include "util/text.hpp"
#include "util/time.hpp"

namespace rtuscope {
namespace {

// Appended as string_views: a `+= "literal"` counts the literal's length with strlen
// at run time.
using namespace std::string_view_literals;

constexpr std::size_t kNoiseBytesShown = 16;
// The record number's width up to 99,999 (wider numbers widen the column from there on);
// the time column's width ("08:00:00.001667"); the indent of the lines under a record
// with those widths.
constexpr std::size_t kNumberColumn = 5;
constexpr std::size_t kTimeColumn = 15;
constexpr std::size_t kUnderIndent = 28;
// Packed values start at tab stops this many columns apart, so that they line up from
// one record to the next.
constexpr std::size_t kValueTab = 10;

// "2026-11-21"
char* write_date(char* p, const CivilDate& date) {
    p = write_digits(p, static_cast<std::uint64_t>(std::max<std::int64_t>(0, date.year)), 4);
    *p++ = '-';
    p = write_digits(p, date.month, 2);
    *p++ = '-';
    return write_digits(p, date.day, 2);
}

// "08:00:00.001667"
char* write_clock(char* p, std::int64_t second_of_day, std::int64_t micros) {
    const auto seconds = static_cast<std::uint64_t>(second_of_day);
    p = write_digits(p, seconds / 3600, 2);
    *p++ = ':';
    p = write_digits(p, seconds / 60 % 60, 2);
    *p++ = ':';
    p = write_digits(p, seconds % 60, 2);
    *p++ = '.';
    return write_digits(p, static_cast<std::uint64_t>(micros), 6);
}

const char* arrow(const Record& r) {
    switch (r.kind) {
        case Kind::request:
        case Kind::broadcast:
            return "▶";
        case Kind::response:
        case Kind::exception:
            return "◀";
        case Kind::invalid:
            if (r.frame.reading == Reading::request) return "▶";
            if (r.frame.reading != Reading::unknown) return "◀";
            return "?";
        case Kind::unknown:
        case Kind::noise:
            return "?";
    }
    return "?";
}

class TextSink final : public RecordSink {
  public:
    TextSink(std::FILE* out, TextOptions options) : out_(out), options_(options) {
        if (options_.fit_terminal) terminal_.emplace(fileno(out));
    }

    void begin(const SessionInfo& s) override {
        base_ = s.source.time_base;
        const TimeFormat format = options_.time_format;
        const bool with_date = format == TimeFormat::local_date || format == TimeFormat::utc_date;
        // Times without a date (a log's time of day) have none to show in the column.
        if (with_date && (base_ == TimeBase::unix_time || base_ == TimeBase::wall_clock)) {
            time_width_ = kTimeColumn + 11;
        } else if (format == TimeFormat::epoch && base_ == TimeBase::unix_time) {
            time_width_ = kTimeColumn + 2;  // "1763798400.001667"
        }
        const LineSettings& line = s.line;
        fmt::print(out_.file(), "{}: {} input, {} {} (t1.5 {:.2f} ms, t3.5 {:.2f} ms){}{}{}\n",
                   s.source.name, s.source.format, line.baud, line.format(),
                   static_cast<double>(line.t15()) / 1e6, static_cast<double>(line.t35()) / 1e6,
                   s.source.timed ? "" : ", no timing", s.batching.empty() ? "" : "; ",
                   s.batching);
        if (!s.devices.empty()) fmt::print(out_.file(), "devices: {}\n", s.devices);
    }

    void record(const Record& r) override {
        std::string& line = out_.line();
        width_ = terminal_ ? terminal_->columns() : options_.width;
        time_text_.clear();
        append_time_column(line, time_text_, r.frame.start);
        const std::size_t line_start = line.size();  // after the date line, if any
        if (const std::size_t digits = decimal_digits(r.number); digits > number_width_) {
            number_width_ = digits;  // the lines under records move with the column
            indent_.clear();
        }
        append_padded(line, r.number, number_width_);
        line += ' ';
        append_padded(line, time_text_, time_width_, true);
        line += "  "sv;
        const bool framed = r.kind != Kind::noise;
        if (framed) {
            append_padded(line, r.frame.slave(), 3);
            line += ' ';
        } else {
            line += "    "sv;
        }
        append_painted(line, arrow(r), colour_of(r));
        line += ' ';

        std::string_view function;
        std::string_view summary;
        if (framed) {
            function = r.decoded.function_name;
            summary = r.decoded.summary;
        } else {
            noise_function_.clear();
            append_summary(noise_function_, r);
            function = noise_function_;
            const auto shown = std::min(r.frame.bytes.size(), kNoiseBytesShown);
            noise_summary_.clear();
            append_hex(noise_summary_, std::span(r.frame.bytes).first(shown), true);
            if (shown < r.frame.bytes.size()) noise_summary_ += " ..."sv;
            summary = noise_summary_;
        }
        column_.clear();
        append_padded(column_, function, 30, false);
        append_painted(line, column_, colour_of(r));
        line += ' ';
        const std::size_t summary_at = line.size();
        line += summary;
        const std::size_t tail_at = line.size();
        if (r.kind == Kind::broadcast) line += "  (broadcast, no answer expected)"sv;
        // Modbus/TCP: the transaction id, as Wireshark's "Trans:", pairs its frames.
        if (framed && r.frame.transport == Transport::tcp) {
            line += "  tid "sv;
            append_uint(line, r.frame.mbap.transaction);
        }
        append_pairing(line, r, "  "sv);
        const std::size_t notes_at = line.size();
        append_notes(line, r.notes);
        // Trailing spaces come from padding a short last column.
        while (!line.empty() && line.back() == ' ') line.pop_back();
        if (indent_.empty()) {
            indent_.assign(kUnderIndent + (time_width_ - kTimeColumn) +
                               (number_width_ - kNumberColumn),
                           ' ');
        }
        if (width_ != 0) {
            fit_record_line(line, line_start, summary_at, std::min(tail_at, line.size()),
                            std::min(notes_at, line.size()));
        }
        line += '\n';
        if (options_.hex && framed) append_hex_lines(line, r.frame.bytes);
        if (options_.values) {
            if (width_ == 0) {
                append_values(line, r.values);
            } else {
                append_packed_values(line, r.values);
            }
            // A line each, whatever the width: a guess cut short could mislead.
            for (std::size_t i = 0; i < r.guesses.size();) {
                line += indent_;
                i = append_guess_line(line, r.guesses, i);
                line += '\n';
            }
        }
        append_comment_lines(line, r.frame.comments);
        out_.record_done();
        if (has_time(r.frame.start)) previous_ = r.frame.start;
    }

    void flush() override { out_.flush(); }

    void end(const Totals& t, const std::vector<std::string>& remarks) override {
        out_.send();
        std::FILE* file = out_.file();
        const auto n = [](std::uint64_t count, std::string_view one, std::string_view many) {
            return fmt::format("{} {}", count, plural(count, one, many));
        };
        fmt::print(file, "-- {}, {}: {}, {}, {}, {}, {} unknown, {} invalid, {} in {}\n",
                   n(t.records, "record", "records"), n(t.bytes, "byte", "bytes"),
                   n(t.requests, "request", "requests"), n(t.responses, "answer", "answers"),
                   n(t.exceptions, "exception", "exceptions"),
                   n(t.broadcasts, "broadcast", "broadcasts"), t.unknown, t.invalid,
                   n(t.noise_bytes, "noise byte", "noise bytes"), n(t.noise_runs, "run", "runs"));
        fmt::print(file, "-- CRC: {} bad, {} swapped; {} without answer; {} without request\n",
                   t.crc_bad, t.crc_swapped, n(t.unanswered, "request", "requests"),
                   n(t.unsolicited, "answer", "answers"));
        if (t.cut_by_stop_bytes != 0) {
            fmt::print(file,
                       "-- note: the run stopped with {} of a frame on the line (not an error)\n",
                       n(t.cut_by_stop_bytes, "byte", "bytes"));
        }
        for (const std::string& remark : remarks) fmt::print(file, "-- note: {}\n", remark);
        flush_output(file);
    }

  private:
    // Cuts the record's line (from `start`) to the width: its summary first, so that the
    // turnaround and the notes after it stay in view. Notes that still do not fit go on a
    // line of their own under it; what does not fit then is cut.
    void fit_record_line(std::string& line, std::size_t start, std::size_t summary_at,
                         std::size_t tail_at, std::size_t notes_at) {
        const auto width_of = [&](std::size_t from, std::size_t to) {
            return display_width(std::string_view(line).substr(from, to - from));
        };
        if (width_of(start, line.size()) <= width_) return;
        // A summary cut to a few columns says nothing.
        constexpr std::size_t kShortestSummary = 12;
        std::size_t fixed = width_of(start, summary_at) + width_of(tail_at, line.size());
        notes_line_.clear();
        if (fixed + kShortestSummary > width_ && notes_at < line.size()) {
            notes_line_ = indent_;
            notes_line_.append(line, notes_at + 2);  // without the two spaces before "!"
            fixed -= width_of(notes_at, line.size());
            line.resize(notes_at);
        }
        tail_.assign(line, tail_at);
        line.resize(tail_at);
        if (fixed + kShortestSummary <= width_) cut_to_width(line, width_ - fixed, summary_at);
        line += tail_;
        cut_to_width(line, width_, start);
        if (!notes_line_.empty()) {
            cut_to_width(notes_line_, width_);
            line += '\n';
            line += notes_line_;
        }
    }

    static std::size_t decimal_digits(std::uint64_t n) {
        std::size_t digits = 1;
        for (; n >= 10; n /= 10) ++digits;
        return digits;
    }

    // One line per value under its frame, with its raw registers: the layout for pipes
    // and files, one value a line for grep and diff.
    void append_values(std::string& out, std::span<const DecodedValue> values) {
        for (std::size_t i = 0; i < values.size();) {
            out += indent_;
            if (values[i].name.empty()) {
                i = append_unlisted_run(out, values, i);
            } else {
                append_value(out, values[i], 16);
                out += " (raw "sv;
                out += values[i].raw;
                out += ')';
                append_notes(out, values[i].notes);
                ++i;
            }
            out += '\n';
        }
    }

    // The values side by side at tab stops, as many as the width takes (a poll of 30
    // registers in a few lines rather than 30); a value wider than the line is cut.
    void append_packed_values(std::string& out, std::span<const DecodedValue> values) {
        const std::size_t room = width_ > indent_.size() ? width_ - indent_.size() : 0;
        std::size_t used = 0;  // columns of the line being filled, past the indent
        for (std::size_t i = 0; i < values.size();) {
            entry_.clear();
            if (values[i].name.empty()) {
                i = append_unlisted_run(entry_, values, i);
            } else {
                append_value(entry_, values[i], 0);
                append_notes(entry_, values[i].notes);
                ++i;
            }
            const std::size_t columns = display_width(entry_);
            // Two spaces at least between values.
            const std::size_t at = (used + 2 + kValueTab - 1) / kValueTab * kValueTab;
            if (used != 0 && at + columns <= room) {
                out.append(at - used, ' ');
                used = at;
            } else {
                if (used != 0) out += '\n';
                out += indent_;
                used = 0;
            }
            const std::size_t line_start = out.size() - (used == 0 ? indent_.size() : 0);
            out += entry_;
            used += columns;
            if (used > room) {
                cut_to_width(out, width_, line_start);
                used = room;
            }
        }
        if (!values.empty()) out += '\n';
    }

    // The comments a pcapng file holds for the frame (someone's in Wireshark), a line for
    // each of their lines under it, whole: what someone wrote is not cut.
    void append_comment_lines(std::string& out, std::span<const std::string> comments) {
        for (const std::string& comment : comments) {
            std::string_view rest = comment;
            while (!rest.empty()) {
                const std::size_t eol = std::min(rest.find('\n'), rest.size());
                out += indent_;
                out += "# "sv;
                out += rest.substr(0, eol);
                out += '\n';
                rest.remove_prefix(std::min(eol + 1, rest.size()));
            }
        }
    }

    // The frame's bytes under it, wrapped at the width.
    void append_hex_lines(std::string& out, std::span<const std::uint8_t> bytes) {
        const std::size_t room = width_ > indent_.size() ? width_ - indent_.size() : 0;
        const std::size_t per_line =
            width_ == 0 ? bytes.size() : std::max<std::size_t>(1, (room + 1) / 3);
        for (std::size_t at = 0; at < bytes.size() || at == 0; at += per_line) {
            out += indent_;
            append_hex(out, bytes.subspan(at, std::min(per_line, bytes.size() - at)), true);
            out += '\n';
            if (bytes.empty()) break;
        }
    }

    // The time column of a record at `time` into `out`; a line saying the date, when it
    // changes, into `line` (the record's own line comes after it).
    void append_time_column(std::string& line, std::string& out, Nanos time) {
        if (!has_time(time)) {
            out += '-';
            return;
        }
        if (!has_time(first_)) first_ = time;
        const TimeFormat format = options_.time_format;
        switch (format) {
            case TimeFormat::relative:
                append_seconds(out, time - first_);
                return;
            case TimeFormat::delta:
                append_seconds(out, has_time(previous_) ? time - previous_ : 0);
                return;
            case TimeFormat::epoch:
                append_seconds(out, time);
                return;
            case TimeFormat::local:
            case TimeFormat::local_date:
            case TimeFormat::utc:
            case TimeFormat::utc_date:
                break;
        }
        // Relative seconds (and the times of a source that said it has none) have no
        // clock to show.
        if (!has_clock(base_)) {
            append_seconds(out, time);
            return;
        }
        // Rounded to the microsecond first, so that the date rolls over with the seconds.
        const std::int64_t micros = floor_div(time, 1000) + (floor_mod(time, 1000) >= 500 ? 1 : 0);
        const std::int64_t seconds = floor_div(micros, 1'000'000);
        const bool local = base_ == TimeBase::unix_time &&
                           (format == TimeFormat::local || format == TimeFormat::local_date);
        if (local) {
            if (seconds != local_second_) {
                local_second_ = seconds;
                local_ = local_time(seconds);
            }
        } else {
            const std::int64_t day = floor_div(seconds, 86'400);
            if (day != local_day_) {
                local_day_ = day;
                local_.date = civil_from_days(day);
            }
            local_.second_of_day = seconds - day * 86'400;
        }
        const bool with_date =
            (format == TimeFormat::local_date || format == TimeFormat::utc_date) &&
            base_ != TimeBase::time_of_day;
        if (!with_date) append_day_line(line, local);
        append_with(out, 32, [&](char* p) {
            if (with_date) {
                p = write_date(p, local_.date);
                *p++ = ' ';
            }
            return write_clock(p, local_.second_of_day, floor_mod(micros, 1'000'000));
        });
    }

    // "-- 2026-11-21 CET (UTC+01:00)" before the first record of a day (and of a new zone:
    // summer time), "-- 2026-11-21 UTC" in UTC, "-- 2024-05-01" for a date read without a
    // zone; "-- day 2 ..." where a log's times of day go past midnight.
    void append_day_line(std::string& line, bool local) {
        const bool same_day = day_shown_ && shown_.date.year == local_.date.year &&
                              shown_.date.month == local_.date.month &&
                              shown_.date.day == local_.date.day;
        if (base_ == TimeBase::time_of_day) {
            if (!day_shown_) {
                day_shown_ = true;
                shown_ = local_;
                return;  // the log's first day, which has no date to show
            }
            if (same_day) return;
            shown_ = local_;
            fmt::format_to(std::back_inserter(line), "-- day {} (the log's times have no date)\n",
                           local_day_ + 1);
            return;
        }
        if (same_day && (!local || shown_.zone == local_.zone)) return;
        day_shown_ = true;
        shown_ = local_;
        line += "-- "sv;
        append_with(line, 10, [&](char* p) { return write_date(p, local_.date); });
        if (base_ == TimeBase::wall_clock) {
            line += '\n';
            return;
        }
        if (!local) {
            line += " UTC\n"sv;
            return;
        }
        const std::int64_t offset = local_.utc_offset;
        const std::int64_t minutes = (offset < 0 ? -offset : offset) / 60;
        if (local_.zone[0] != '\0') {
            line += ' ';
            line += local_.zone.data();
        }
        if (offset == 0 && std::string_view(local_.zone.data()) == "UTC") {
            line += '\n';
            return;
        }
        fmt::format_to(std::back_inserter(line), " (UTC{}{:02}:{:02})\n", offset < 0 ? '-' : '+',
                       minutes / 60, minutes % 60);
    }

    static fmt::terminal_color colour_of(const Record& r) {
        switch (r.kind) {
            case Kind::response:
                return fmt::terminal_color::cyan;
            case Kind::exception:
                return fmt::terminal_color::yellow;
            case Kind::invalid:
            case Kind::noise:
                return fmt::terminal_color::red;
            default:
                return fmt::terminal_color::white;
        }
    }

    // A frame's or a value's notes at the end of its line: "  ! first; second".
    void append_notes(std::string& out, std::span<const Note> notes) {
        if (notes.empty()) return;
        notes_text_ = "! ";
        append_note_texts(notes_text_, notes);
        out += "  "sv;
        append_painted(out, notes_text_, fmt::terminal_color::yellow);
    }

    void append_painted(std::string& out, std::string_view text, fmt::terminal_color colour) const {
        if (!options_.color || colour == fmt::terminal_color::white) {
            out += text;
        } else {
            fmt::format_to(std::back_inserter(out), "{}", fmt::styled(text, fmt::fg(colour)));
        }
    }

    BlockOutput out_;
    TextOptions options_;
    // Pieces of a line, reused.
    std::string time_text_;
    std::string column_;
    std::string noise_function_;
    std::string noise_summary_;
    std::string notes_text_;
    std::string entry_;
    std::string tail_;
    std::string notes_line_;
    Nanos first_ = kNoTime;
    Nanos previous_ = kNoTime;
    // The columns: what the times are, the widths, the indent under a record; the width
    // to fit (0: none).
    TimeBase base_ = TimeBase::none;
    std::size_t number_width_ = kNumberColumn;
    std::size_t time_width_ = kTimeColumn;
    std::string indent_;
    std::optional<TerminalWidth> terminal_;
    std::size_t width_ = 0;
    // The last record's date and time of day, worked out again only when its second (its
    // day, outside the local zone) changes; and the date the last day line showed.
    LocalTime local_;
    std::int64_t local_second_ = std::numeric_limits<std::int64_t>::min();
    std::int64_t local_day_ = std::numeric_limits<std::int64_t>::min();
    LocalTime shown_;
    bool day_shown_ = false;
};

}  // namespace

std::unique_ptr<RecordSink> make_text_sink(std::FILE* out, TextOptions options) {
    return std::make_unique<TextSink>(out, options);
}

}  // namespace rtuscope
