// The per-frame CSV of DESIGN.md: RFC 4180, the documented columns first in their order.
#include <fmt/format.h>

#include "rtuscope/sinks.hpp"

namespace rtuscope {
namespace {

class CsvSink final : public RecordSink {
  public:
    explicit CsvSink(std::FILE* out) : out_(out) {}

    void begin(const SessionInfo& /*session*/) override {
        std::fputs(
            "frame,time,slave,function,kind,crc,request,latency_ms,summary,hex,flags,notes\n",
            out_);
    }

    void record(const Record& r) override {
        line_.clear();
        const bool framed = r.kind != Kind::noise;
        fmt::format_to(std::back_inserter(line_), "{},", r.number);
        append_seconds(line_, r.frame.start);
        line_ += ',';
        if (framed && !r.frame.bytes.empty()) append_int(r.frame.slave());
        line_ += ',';
        if (framed && r.frame.bytes.size() >= 2) append_int(r.frame.function());
        line_ += ',';
        line_ += to_string(r.kind);
        line_ += ',';
        line_ += to_string(r.frame.crc.status);
        line_ += ',';
        if (r.request_number != 0) append_int(r.request_number);
        line_ += ',';
        if (has_time(r.latency)) {
            fmt::format_to(std::back_inserter(line_), "{:.3f}",
                           static_cast<double>(r.latency) / 1e6);
        }
        line_ += ',';
        field_.clear();
        append_summary(field_, r);
        append_csv_field(line_, field_);
        line_ += ',';
        append_hex(line_, r.frame.bytes, false);
        line_ += ',';
        if (!r.notes.empty() || !r.values.empty()) {
            const RecordFlags flags = record_flags(r);
            field_.clear();
            for (const std::string& id : flags.ids) {
                if (!field_.empty()) field_ += ' ';
                field_ += id;
            }
            append_csv_field(line_, field_);
            line_ += ',';
            field_.clear();
            for (const std::string& text : flags.texts) {
                if (!field_.empty()) field_ += "; ";
                field_ += text;
            }
            append_csv_field(line_, field_);
        } else {
            line_ += ',';
        }
        line_ += '\n';
        std::fwrite(line_.data(), 1, line_.size(), out_);
    }

    void flush() override { std::fflush(out_); }

    void end(const Totals& /*totals*/, const std::vector<std::string>& /*remarks*/) override {
        std::fflush(out_);
    }

  private:
    void append_int(std::uint64_t value) {
        const fmt::format_int text(value);
        line_.append(text.data(), text.size());
    }

    std::FILE* out_;
    std::string line_;   // the row being built, reused
    std::string field_;  // one field before quoting, reused
};

}  // namespace

std::unique_ptr<RecordSink> make_csv_sink(std::FILE* out) {
    return std::make_unique<CsvSink>(out);
}

}  // namespace rtuscope
