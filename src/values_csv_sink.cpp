// One CSV row per register value (--values-csv): the columns of issue #3 first
// (time,slave,profile,address,name,value,unit,raw), then the record it came from (its
// number, kind and CRC status, so that a value from a damaged frame is never taken for a
// good one) and the value's notes.
#include <fmt/format.h>

#include "rtuscope/sinks.hpp"

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
        for (const DecodedValue& v : r.values) {
            std::string ids;
            std::string texts;
            // Appended piece by piece: `"..." + std::string` here drew a false -Wrestrict
            // from GCC 12 at -O3 (the benchmarks' Release build).
            for (const Note& note : v.notes) {
                if (!ids.empty()) ids += ' ';
                ids += note.id;
                if (!texts.empty()) texts += "; ";
                texts += note.text;
            }
            std::string line = fmt::format("{},{},{},0x{:04X},", seconds_text(r.frame.start),
                                           r.frame.slave(), csv_field(r.profile->name), v.address);
            line += csv_field(v.name) + ',' + csv_field(v.value) + ',' + csv_field(v.unit) + ',' +
                    csv_field(v.raw) + ',' + std::to_string(r.number) + ',';
            line += to_string(r.kind);
            line += ',';
            line += to_string(r.frame.crc.status);
            line += ',' + csv_field(ids) + ',' + csv_field(texts) + '\n';
            write_output(out_, line);
        }
    }

    void flush() override { flush_output(out_); }

    void end(const Totals& /*totals*/, const std::vector<std::string>& /*remarks*/) override {
        flush_output(out_);
    }

  private:
    std::FILE* out_;
};

}  // namespace

std::unique_ptr<RecordSink> make_values_csv_sink(std::FILE* out) {
    return std::make_unique<ValuesCsvSink>(out);
}

}  // namespace rtuscope
