// --jsonl: one JSON object per record, for log pipelines (Fluent Bit, Vector, Kafka
// consumers). The schema is documented in README.md ("JSON Lines"); keys are only ever
// added, never renamed or retyped. Unknown values are null, never omitted, so that every
// line has the same keys.
#include <fmt/format.h>

#include "rtuscope/decoder.hpp"
#include "rtuscope/sinks.hpp"
#include "text_append.hpp"

namespace rtuscope {
namespace {

std::string json_list(const std::vector<std::string>& items) {
    std::string out = "[";
    for (std::size_t i = 0; i < items.size(); ++i)
        out += (i > 0 ? "," : "") + json_string(items[i]);
    return out + "]";
}

// A value as a JSON number when it is a plain decimal ("220.5", "-5.0", "12345"), else
// as a string (an enum label, bit names, a special write's meaning); null when unknown.
std::string json_value(const std::string& value) {
    if (value.empty()) return "null";
    std::size_t i = value[0] == '-' ? 1 : 0;
    const std::size_t digits_from = i;
    while (i < value.size() && value[i] >= '0' && value[i] <= '9') ++i;
    bool number = i > digits_from && (i - digits_from == 1 || value[digits_from] != '0');
    if (number && i < value.size() && value[i] == '.') {
        const std::size_t fraction = ++i;
        while (i < value.size() && value[i] >= '0' && value[i] <= '9') ++i;
        number = i > fraction;
    }
    return number && i == value.size() ? value : json_string(value);
}

std::string millis_text(Nanos duration) {
    std::string out;
    append_with(out, kMaxMillisChars, [&](char* p) { return write_millis(p, duration, 3); });
    return out;
}

class JsonlSink final : public RecordSink {
  public:
    explicit JsonlSink(std::FILE* out) : out_(out) {}

    void begin(const SessionInfo& /*session*/) override {}

    void record(const Record& r) override {
        const bool framed = r.kind != Kind::noise;
        const std::string time = seconds_text(r.frame.start);
        const RecordFlags flags = record_flags(r);
        std::string line =
            fmt::format("{{\"frame\":{},\"time\":{},", r.number, time.empty() ? "null" : time);
        line += fmt::format("\"slave\":{},", framed && !r.frame.bytes.empty()
                                                 ? std::to_string(r.frame.slave())
                                                 : "null");
        line += fmt::format("\"function\":{},", framed && r.frame.bytes.size() >= 2
                                                    ? std::to_string(r.frame.function())
                                                    : "null");
        line += fmt::format("\"kind\":\"{}\",\"crc\":\"{}\",", to_string(r.kind),
                            to_string(r.frame.crc.status));
        line += fmt::format("\"request\":{},",
                            r.request_number != 0 ? std::to_string(r.request_number) : "null");
        line += fmt::format("\"latency_ms\":{},",
                            has_time(r.latency) ? millis_text(r.latency) : "null");
        line += "\"summary\":" + json_string(record_summary(r)) + ",";
        line += "\"hex\":\"" + hex_bytes(r.frame.bytes, false) + "\",";
        line += "\"flags\":" + json_list(flags.ids) + ",\"notes\":" + json_list(flags.texts) + ",";
        line += "\"channel\":" + (r.frame.channel.empty() ? "null" : json_string(r.frame.channel));
        line += ",\"function_name\":" +
                (framed ? json_string(r.decoded.function_name) : std::string("null"));
        if (r.decoded.exception) {
            const char* name = exception_name(r.decoded.exception_code);
            line += fmt::format(",\"exception\":{{\"code\":{},\"name\":{}}}",
                                r.decoded.exception_code, name ? json_string(name) : "null");
        } else {
            line += ",\"exception\":null";
        }
        line += ",\"profile\":" + (r.profile ? json_string(r.profile->name) : "null");
        line += ",\"values\":[";
        for (std::size_t i = 0; i < r.values.size(); ++i) {
            const DecodedValue& v = r.values[i];
            std::vector<std::string> ids;
            std::vector<std::string> texts;
            for (const Note& n : v.notes) {
                ids.emplace_back(n.id);
                texts.push_back(n.text);
            }
            line += fmt::format(
                "{}{{\"address\":{},\"name\":{},\"value\":{},\"unit\":{},\"raw\":{},\"flags\":{},"
                "\"notes\":{}}}",
                i > 0 ? "," : "", v.address, v.name.empty() ? "null" : json_string(v.name),
                json_value(v.value), json_string(v.unit), json_string(v.raw), json_list(ids),
                json_list(texts));
        }
        line += "]}\n";
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

std::unique_ptr<RecordSink> make_jsonl_sink(std::FILE* out) {
    return std::make_unique<JsonlSink>(out);
}

}  // namespace rtuscope
