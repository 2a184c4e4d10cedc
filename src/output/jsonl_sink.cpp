// --jsonl: one JSON object per record, for log pipelines (Fluent Bit, Vector, Kafka
// consumers). The schema is documented in docs/formats.md ("JSON Lines"); keys are only ever
// added, never renamed or retyped. Unknown values are null, never omitted, so that every
// line has the same keys.
#include "decode/decoder.hpp"
#include "output/block_output.hpp"
#include "output/fields.hpp"
#include "output/sinks.hpp"
#include "util/text.hpp"

namespace rtuscope {
namespace {

// Appended as string_views: a `+= "literal"` counts the literal's length with strlen
// at run time, some thirty times a line.
using namespace std::string_view_literals;

// A value as a JSON number when it is a plain decimal ("220.5", "-5.0", "12345"), else
// as a string (an enum label, bit names, a special write's meaning); null when unknown.
void append_json_value(std::string& out, std::string_view value) {
    if (value.empty()) {
        out += "null"sv;
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
        std::string& line = out_.line();
        auto append_number_or_null = [&](bool known, std::uint64_t value) {
            if (known) {
                append_uint(line, value);
            } else {
                line += "null"sv;
            }
        };
        line += "{\"frame\":"sv;
        append_uint(line, r.number);
        line += ",\"time\":"sv;
        if (has_time(r.frame.start)) {
            append_seconds(line, r.frame.start);
        } else {
            line += "null"sv;
        }
        line += ",\"slave\":"sv;
        append_number_or_null(framed && !r.frame.bytes.empty(), r.frame.slave());
        line += ",\"function\":"sv;
        append_number_or_null(framed && r.frame.bytes.size() >= 2, r.frame.function());
        line += ",\"kind\":\""sv;
        line += to_string(r.kind);
        line += "\",\"crc\":\""sv;
        line += to_string(r.frame.crc.status);
        line += "\",\"request\":"sv;
        append_number_or_null(r.request_number != 0, r.request_number);
        line += ",\"latency_ms\":"sv;
        if (has_time(r.latency)) {
            append_with(line, kMaxMillisChars,
                        [&](char* p) { return write_millis(p, r.latency, 3); });
        } else {
            line += "null"sv;
        }
        line += ",\"summary\":"sv;
        summary_.clear();
        append_summary(summary_, r);
        append_json_string(line, summary_);
        line += ",\"hex\":\""sv;
        append_hex(line, r.frame.bytes, false);
        line += "\",\"flags\":"sv;
        flags_.build(r, ",", ",", [](std::string& out, std::string_view item) {
            append_json_string(out, item);
        });
        line += '[';
        line += flags_.ids;
        line += "],\"notes\":["sv;
        line += flags_.texts;
        line += ']';
        line += ",\"channel\":"sv;
        if (r.frame.channel.empty()) {
            line += "null"sv;
        } else {
            append_json_string(line, r.frame.channel);
        }
        line += ",\"function_name\":"sv;
        if (framed) {
            append_json_string(line, r.decoded.function_name);
        } else {
            line += "null"sv;
        }
        line += ",\"exception\":"sv;
        if (r.decoded.exception) {
            line += "{\"code\":"sv;
            append_uint(line, r.decoded.exception_code);
            line += ",\"name\":"sv;
            const char* name = exception_name(r.decoded.exception_code);
            if (name != nullptr) {
                append_json_string(line, name);
            } else {
                line += "null"sv;
            }
            line += '}';
        } else {
            line += "null"sv;
        }
        line += ",\"profile\":"sv;
        if (r.profile != nullptr) {
            append_json_string(line, r.profile->name);
        } else {
            line += "null"sv;
        }
        line += ",\"values\":["sv;
        for (std::size_t i = 0; i < r.values.size(); ++i) {
            const DecodedValue& v = r.values[i];
            if (i > 0) line += ',';
            append_value_object(line, v.address, v.name, v.value, v.unit, v.raw);
            for (std::size_t n = 0; n < v.notes.size(); ++n) {
                if (n > 0) line += ',';
                append_json_string(line, v.notes[n].id);
            }
            line += "],\"notes\":["sv;
            for (std::size_t n = 0; n < v.notes.size(); ++n) {
                if (n > 0) line += ',';
                append_json_string(line, v.notes[n].text);
            }
            line += "]}"sv;
        }
        // --guess: each reading a value of its own, flagged value.guess.
        for (std::size_t i = 0; i < r.guesses.size(); ++i) {
            const GuessedReading& g = r.guesses[i];
            if (i > 0 || !r.values.empty()) line += ',';
            append_value_object(line, g.address, reading_name(g.reading), g.value, {}, g.raw);
            append_json_string(line, note_id::value_guess);
            line += "],\"notes\":["sv;
            append_json_string(line, kGuessNoteText);
            line += "]}"sv;
        }
        line += "],\"transport\":\""sv;
        line += to_string(r.frame.transport);
        line += "\",\"transaction\":"sv;
        append_number_or_null(r.frame.transport == Transport::tcp, r.frame.mbap.transaction);
        line += "}\n"sv;
        out_.record_done();
    }

    void flush() override { out_.flush(); }

    void end(const Totals& /*totals*/, const std::vector<std::string>& /*remarks*/) override {
        flush();
    }

  private:
    // A value's keys up to its flags, whose list is left open.
    static void append_value_object(std::string& line, std::uint16_t address,
                                    std::string_view name, std::string_view value,
                                    std::string_view unit, std::string_view raw) {
        line += "{\"address\":"sv;
        append_uint(line, address);
        line += ",\"name\":"sv;
        if (name.empty()) {
            line += "null"sv;
        } else {
            append_json_string(line, name);
        }
        line += ",\"value\":"sv;
        append_json_value(line, value);
        line += ",\"unit\":"sv;
        append_json_string(line, unit);
        line += ",\"raw\":"sv;
        append_json_string(line, raw);
        line += ",\"flags\":["sv;
    }

    BlockOutput out_;
    std::string summary_;  // reused
    FlagColumns flags_;
};

}  // namespace

std::unique_ptr<RecordSink> make_jsonl_sink(std::FILE* out) {
    return std::make_unique<JsonlSink>(out);
}

}  // namespace rtuscope
