// --jsonl: one JSON object per record, for log pipelines (Fluent Bit, Vector, Kafka
// consumers). The schema is documented in README.md ("JSON Lines"); keys are only ever
// added, never renamed or retyped. Unknown values are null, never omitted, so that every
// line has the same keys.
#include "rtuscope/decoder.hpp"
#include "rtuscope/sinks.hpp"
#include "text_append.hpp"

namespace rtuscope {
namespace {

void append_json_list(std::string& out, const std::vector<std::string>& items) {
    out += '[';
    for (std::size_t i = 0; i < items.size(); ++i) {
        if (i > 0) out += ',';
        append_json_string(out, items[i]);
    }
    out += ']';
}

// A value as a JSON number when it is a plain decimal ("220.5", "-5.0", "12345"), else
// as a string (an enum label, bit names, a special write's meaning); null when unknown.
void append_json_value(std::string& out, const std::string& value) {
    if (value.empty()) {
        out += "null";
        return;
    }
    std::size_t i = value[0] == '-' ? 1 : 0;
    const std::size_t digits_from = i;
    while (i < value.size() && value[i] >= '0' && value[i] <= '9') ++i;
    bool number = i > digits_from && (i - digits_from == 1 || value[digits_from] != '0');
    if (number && i < value.size() && value[i] == '.') {
        const std::size_t fraction = ++i;
        while (i < value.size() && value[i] >= '0' && value[i] <= '9') ++i;
        number = i > fraction;
    }
    if (number && i == value.size()) {
        out += value;
    } else {
        append_json_string(out, value);
    }
}

class JsonlSink final : public RecordSink {
  public:
    explicit JsonlSink(std::FILE* out) : out_(out) {}

    void begin(const SessionInfo& /*session*/) override {}

    void record(const Record& r) override {
        const bool framed = r.kind != Kind::noise;
        std::string& line = out_.text();
        auto append_number_or_null = [&](bool known, std::uint64_t value) {
            if (known) {
                append_uint(line, value);
            } else {
                line += "null";
            }
        };
        line += "{\"frame\":";
        append_uint(line, r.number);
        line += ",\"time\":";
        if (has_time(r.frame.start)) {
            append_seconds(line, r.frame.start);
        } else {
            line += "null";
        }
        line += ",\"slave\":";
        append_number_or_null(framed && !r.frame.bytes.empty(), r.frame.slave());
        line += ",\"function\":";
        append_number_or_null(framed && r.frame.bytes.size() >= 2, r.frame.function());
        line += ",\"kind\":\"";
        line += to_string(r.kind);
        line += "\",\"crc\":\"";
        line += to_string(r.frame.crc.status);
        line += "\",\"request\":";
        append_number_or_null(r.request_number != 0, r.request_number);
        line += ",\"latency_ms\":";
        if (has_time(r.latency)) {
            append_with(line, kMaxMillisChars,
                        [&](char* p) { return write_millis(p, r.latency, 3); });
        } else {
            line += "null";
        }
        line += ",\"summary\":";
        summary_.clear();
        append_summary(summary_, r);
        append_json_string(line, summary_);
        line += ",\"hex\":\"";
        append_hex(line, r.frame.bytes, false);
        line += "\",\"flags\":";
        // Only notes and values give flags.
        const RecordFlags flags =
            r.notes.empty() && r.values.empty() ? RecordFlags{} : record_flags(r);
        append_json_list(line, flags.ids);
        line += ",\"notes\":";
        append_json_list(line, flags.texts);
        line += ",\"channel\":";
        if (r.frame.channel.empty()) {
            line += "null";
        } else {
            append_json_string(line, r.frame.channel);
        }
        line += ",\"function_name\":";
        if (framed) {
            append_json_string(line, r.decoded.function_name);
        } else {
            line += "null";
        }
        line += ",\"exception\":";
        if (r.decoded.exception) {
            line += "{\"code\":";
            append_uint(line, r.decoded.exception_code);
            line += ",\"name\":";
            const char* name = exception_name(r.decoded.exception_code);
            if (name != nullptr) {
                append_json_string(line, name);
            } else {
                line += "null";
            }
            line += '}';
        } else {
            line += "null";
        }
        line += ",\"profile\":";
        if (r.profile != nullptr) {
            append_json_string(line, r.profile->name);
        } else {
            line += "null";
        }
        line += ",\"values\":[";
        for (std::size_t i = 0; i < r.values.size(); ++i) {
            const DecodedValue& v = r.values[i];
            if (i > 0) line += ',';
            line += "{\"address\":";
            append_uint(line, v.address);
            line += ",\"name\":";
            if (v.name.empty()) {
                line += "null";
            } else {
                append_json_string(line, v.name);
            }
            line += ",\"value\":";
            append_json_value(line, v.value);
            line += ",\"unit\":";
            append_json_string(line, v.unit);
            line += ",\"raw\":";
            append_json_string(line, v.raw);
            line += ",\"flags\":[";
            for (std::size_t n = 0; n < v.notes.size(); ++n) {
                if (n > 0) line += ',';
                append_json_string(line, v.notes[n].id);
            }
            line += "],\"notes\":[";
            for (std::size_t n = 0; n < v.notes.size(); ++n) {
                if (n > 0) line += ',';
                append_json_string(line, v.notes[n].text);
            }
            line += "]}";
        }
        line += "]}\n";
        out_.record_done();
    }

    void flush() override {
        out_.send();
        std::fflush(out_.file());
    }

    void end(const Totals& /*totals*/, const std::vector<std::string>& /*remarks*/) override {
        flush();
    }

  private:
    BlockOutput out_;
    std::string summary_;  // reused
};

}  // namespace

std::unique_ptr<RecordSink> make_jsonl_sink(std::FILE* out) {
    return std::make_unique<JsonlSink>(out);
}

}  // namespace rtuscope
