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
        const bool framed = r.kind != Kind::noise;
        const RecordFlags flags = record_flags(r);
        std::string ids;
        for (const std::string& id : flags.ids) ids += (ids.empty() ? "" : " ") + id;
        std::string texts;
        for (const std::string& text : flags.texts) texts += (texts.empty() ? "" : "; ") + text;
        std::string line = fmt::format("{},{},", r.number, seconds_text(r.frame.start));
        if (framed && !r.frame.bytes.empty()) line += fmt::format("{}", r.frame.slave());
        line += ',';
        if (framed && r.frame.bytes.size() >= 2) line += fmt::format("{}", r.frame.function());
        line += fmt::format(",{},{},", to_string(r.kind), to_string(r.frame.crc.status));
        if (r.request_number != 0) line += fmt::format("{}", r.request_number);
        line += ',';
        if (has_time(r.latency))
            line += fmt::format("{:.3f}", static_cast<double>(r.latency) / 1e6);
        line += ',';
        line += csv_field(record_summary(r));
        line += ',';
        line += hex_bytes(r.frame.bytes, false);
        line += ',';
        line += csv_field(ids);
        line += ',';
        line += csv_field(texts);
        line += '\n';
        std::fwrite(line.data(), 1, line.size(), out_);
    }

    void flush() override { std::fflush(out_); }

    void end(const Totals& /*totals*/, const std::vector<std::string>& /*remarks*/) override {
        std::fflush(out_);
    }

  private:
    std::FILE* out_;
};

}  // namespace

std::unique_ptr<RecordSink> make_csv_sink(std::FILE* out) {
    return std::make_unique<CsvSink>(out);
}

}  // namespace rtuscope
