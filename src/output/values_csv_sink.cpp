// One CSV row per register value (--values-csv): the value's own columns first
// (time,slave,profile,address,name,value,unit,raw), then the record it came from (its
// number, kind and CRC status, so that a value from a damaged frame is never taken for a
// good one) and the value's notes. --guess adds a row per guessed reading, flagged
// value.guess, its reading ("f32/cdab") in the name column.
#include <fmt/format.h>

#include "output/block_output.hpp"
#include "output/fields.hpp"
#include "output/sinks.hpp"
#include "util/text.hpp"

namespace rtuscope {
namespace {

class ValuesCsvSink final : public RecordSink {
  public:
    explicit ValuesCsvSink(std::FILE* out) : out_(out) {}

    void begin(const SessionInfo& /*session*/) override {
        std::fputs("time,slave,profile,address,name,value,unit,raw,frame,kind,crc,flags,notes\n",
                   out_);
    }

    void record(const Record& r) override {
        // Each row is built in the same strings, which keep their room: a row allocates
        // nothing once the longest has been written. Appended piece by piece (`"..." +
        // std::string` draws a false -Wrestrict from GCC 12 at -O3).
        for (const DecodedValue& v : r.values) {
            ids_.clear();
            texts_.clear();
            for (const Note& note : v.notes) {
                if (!ids_.empty()) ids_ += ' ';
                ids_ += note.id;
                if (!texts_.empty()) texts_ += "; ";
                texts_ += note.text;
            }
            write_row(r, v.address, v.name, v.value, v.unit, v.raw);
        }
        for (const GuessedReading& g : r.guesses) {
            ids_ = note_id::value_guess;
            texts_ = kGuessNoteText;
            write_row(r, g.address, reading_name(g.reading), g.value, {}, g.raw);
        }
    }

    void flush() override { flush_output(out_); }

    void end(const Totals& /*totals*/, const std::vector<std::string>& /*remarks*/) override {
        flush_output(out_);
    }

  private:
    void write_row(const Record& r, std::uint16_t address, std::string_view name,
                   std::string_view value, std::string_view unit, std::string_view raw) {
        line_.clear();
        append_seconds(line_, r.frame.start);
        fmt::format_to(std::back_inserter(line_), ",{},", r.frame.slave());
        // A guess may be of a slave without a profile.
        if (r.profile != nullptr) append_csv_field(line_, r.profile->name);
        fmt::format_to(std::back_inserter(line_), ",0x{:04X},", address);
        for (const std::string_view field : {name, value, unit, raw}) {
            append_csv_field(line_, field);
            line_ += ',';
        }
        fmt::format_to(std::back_inserter(line_), "{},{},{},", r.number, to_string(r.kind),
                       to_string(r.frame.crc.status));
        append_csv_field(line_, ids_);
        line_ += ',';
        append_csv_field(line_, texts_);
        line_ += '\n';
        write_output(out_, line_);
    }

    std::FILE* out_;
    std::string line_;
    std::string ids_;    // the value's note ids, space-separated
    std::string texts_;  // and their texts, "; "-separated
};

}  // namespace

std::unique_ptr<RecordSink> make_values_csv_sink(std::FILE* out) {
    return std::make_unique<ValuesCsvSink>(out);
}

}  // namespace rtuscope
