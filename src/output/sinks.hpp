// Stage 5, sinks: annotated text for people, CSV and JSON Lines for programs
// (docs/formats.md), all fed one record at a time.
#pragma once

#include <algorithm>
#include <cstdio>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "pipeline.hpp"

namespace rtuscope {

// The text's time column, tshark's -t letters: a (the default), ad, u, ud, r, d, e.
enum class TimeFormat : std::uint8_t {
    local,       // a: local time of day (TZ applies), a line with the date when it changes
    local_date,  // ad: local date and time
    utc,         // u: UTC time of day, a line with the date when it changes
    utc_date,    // ud: UTC date and time
    relative,    // r: seconds since the first record
    delta,       // d: seconds since the previous record
    epoch,       // e: seconds as in the CSV time column (Unix time for absolute times)
};
// Times read without a zone (a log's date and time, or time of day) show as read in a,
// ad, u and ud; relative times show as seconds (SourceInfo::time_base).

struct TextOptions {
    bool color = false;
    bool hex = false;  // the raw bytes of every record on a line of their own
    TimeFormat time_format = TimeFormat::local;
    bool values = true;  // the register values under their frame
    // Columns to fit: values packed side by side, frame lines cut with "…", bytes of
    // --hex wrapped. 0: one value per line, lines whole (for pipes and files).
    std::size_t width = 0;
    // Fit stdout's terminal instead, following its resizes (over `width`).
    bool fit_terminal = false;
};

std::unique_ptr<RecordSink> make_text_sink(std::FILE* out, TextOptions options);
std::unique_ptr<RecordSink> make_csv_sink(std::FILE* out);
// One row per register value (records without a profile give none).
std::unique_ptr<RecordSink> make_values_csv_sink(std::FILE* out);
// One JSON object per record (JSON Lines): the per-frame CSV's fields, the decoded
// fields and the register values; schema in docs/formats.md.
std::unique_ptr<RecordSink> make_jsonl_sink(std::FILE* out);

// "3 registers not in the profile".
void append_unlisted_registers_text(std::string& out, std::size_t count);

// The `flags` and `notes` columns of a record: its notes, then its register values'
// anomalies ("name: text"; so that filtering by flag finds a value out of range without
// the values CSV), then the registers the profile does not list, only counted;
// `ids` lists each id once, `texts` every text. Built in strings reused record after
// record (a list of strings per record would be a large part of decoding with profiles);
// `write(out, item)` writes one item (as it is for the CSV, as a JSON string for JSONL),
// after the separator when it is not the first.
class FlagColumns {
  public:
    template <typename Write>
    void build(const Record& record, std::string_view id_separator, std::string_view text_separator,
               Write write) {
        ids.clear();
        texts.clear();
        seen_.clear();
        auto add = [&](std::string_view id, std::string_view text) {
            if (std::find(seen_.begin(), seen_.end(), id) == seen_.end()) {
                seen_.push_back(id);
                if (!ids.empty()) ids += id_separator;
                write(ids, id);
            }
            if (!texts.empty()) texts += text_separator;
            write(texts, text);
        };
        for (const Note& note : record.notes) add(note.id, note.text);
        std::size_t unlisted = 0;
        for (const DecodedValue& v : record.values) {
            for (const Note& note : v.notes) {
                if (std::string_view(note.id) == note_id::value_unlisted) {
                    ++unlisted;
                    continue;
                }
                named_ = v.name;
                named_ += ": ";
                named_ += note.text;
                add(note.id, named_);
            }
        }
        if (unlisted > 0) {
            named_.clear();
            append_unlisted_registers_text(named_, unlisted);
            add(note_id::value_unlisted, named_);
        }
    }

    std::string ids;
    std::string texts;

  private:
    std::vector<std::string_view> seen_;  // the ids so far
    std::string named_;                   // a value's note with its name
};

// The one-line description of a record, as in the CSV `summary` column.
void append_summary(std::string& out, const Record& record);

}  // namespace rtuscope
