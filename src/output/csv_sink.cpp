// The per-frame CSV of docs/formats.md: RFC 4180, the documented columns first in their order.
#include "output/block_output.hpp"
#include "output/fields.hpp"
#include "output/sinks.hpp"
#include "util/text.hpp"

namespace rtuscope {
namespace {

class CsvSink final : public RecordSink {
  public:
    explicit CsvSink(std::FILE* out) : out_(out) {}

    void begin(const SessionInfo& /*session*/) override {
        std::fputs(
            "frame,time,slave,function,kind,crc,request,latency_ms,summary,hex,flags,notes\n",
            out_.file());
    }

    void record(const Record& r) override {
        const bool framed = r.kind != Kind::noise;
        // A frame's summary is its function's name and what it carries, written as one
        // field straight from the two; noise says how long it is.
        std::string_view name = r.decoded.function_name;
        std::string_view carried = r.decoded.summary;
        if (!framed) {
            summary_.clear();
            append_summary(summary_, r);
            name = summary_;
            carried = {};
        }
        flags_.build(r, " ", "; ", [](std::string& out, std::string_view item) { out += item; });
        // Numbers, time, kind, CRC, latency and commas fit in kFixedChars; quoting at most
        // doubles a field and adds two quotes.
        constexpr std::size_t kFixedChars =
            4 * kMaxUintChars + kMaxSecondsChars + kMaxMillisChars + 50;
        const std::size_t bound = kFixedChars + 2 * r.frame.bytes.size() + 2 * name.size() +
                                  2 * carried.size() + 2 + 2 * flags_.ids.size() +
                                  2 * flags_.texts.size() + 6;
        out_.write(bound, [&](char* p) {
            p = write_uint(p, r.number);
            *p++ = ',';
            p = write_seconds(p, r.frame.start);
            *p++ = ',';
            if (framed && !r.frame.bytes.empty()) p = write_uint(p, r.frame.slave());
            *p++ = ',';
            if (framed && r.frame.bytes.size() >= 2) p = write_uint(p, r.frame.function());
            *p++ = ',';
            p = write_text(p, to_string(r.kind));
            *p++ = ',';
            p = write_text(p, to_string(r.frame.crc.status));
            *p++ = ',';
            if (r.request_number != 0) p = write_uint(p, r.request_number);
            *p++ = ',';
            if (has_time(r.latency)) p = write_millis(p, r.latency, 3);
            *p++ = ',';
            p = write_csv_field(p, name, carried);
            *p++ = ',';
            p = write_hex(p, r.frame.bytes, false);
            *p++ = ',';
            p = write_csv_field(p, flags_.ids);
            *p++ = ',';
            p = write_csv_field(p, flags_.texts);
            *p++ = '\n';
            return p;
        });
    }

    void flush() override { out_.flush(); }

    void end(const Totals& /*totals*/, const std::vector<std::string>& /*remarks*/) override {
        flush();
    }

  private:
    BlockOutput out_;
    // Fields that may need quoting, built before they are written; all reused.
    std::string summary_;  // noise only
    FlagColumns flags_;
};

}  // namespace

std::unique_ptr<RecordSink> make_csv_sink(std::FILE* out) {
    return std::make_unique<CsvSink>(out);
}

}  // namespace rtuscope
