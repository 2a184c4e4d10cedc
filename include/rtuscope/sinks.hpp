// Stage 5, sinks: annotated text for people, the per-frame CSV of DESIGN.md for machines.
#pragma once

#include <cstdio>
#include <memory>
#include <string>

#include "rtuscope/pipeline.hpp"

namespace rtuscope {

// tshark's habit: absolute by default, relative to the first record, delta to previous.
enum class TimeFormat : std::uint8_t { absolute, relative, delta };

struct TextOptions {
    bool color = false;
    bool hex = false;  // the raw bytes of every record on a line of their own
    TimeFormat time_format = TimeFormat::absolute;
};

std::unique_ptr<RecordSink> make_text_sink(std::FILE* out, TextOptions options);
std::unique_ptr<RecordSink> make_csv_sink(std::FILE* out);
// One row per register value (records without a profile give none).
std::unique_ptr<RecordSink> make_values_csv_sink(std::FILE* out);

// Shared by the sinks: "01 03 00 00" (spaced) or "01030000".
std::string hex_bytes(std::span<const std::uint8_t> bytes, bool spaced);
// Seconds with 6 decimals in the input's timebase ("1763798400.022360"); empty if none.
std::string seconds_text(Nanos time);
// An RFC 4180 field: quoted when it holds a comma, a quote or a line break.
std::string csv_field(std::string_view text);
// The one-line description of a record, as in the CSV `summary` column.
std::string record_summary(const Record& record);

}  // namespace rtuscope
