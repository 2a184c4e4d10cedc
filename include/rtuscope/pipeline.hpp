// The whole pipeline, source to sink: what `decode` (and later `sniff`) runs.
//   source --chunks--> framer --frames--> transactions --records--> decoder --> sink
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "rtuscope/chunk.hpp"
#include "rtuscope/line_settings.hpp"
#include "rtuscope/protocol_rules.hpp"
#include "rtuscope/result.hpp"
#include "rtuscope/transactions.hpp"

namespace rtuscope {

struct PipelineOptions {
    std::optional<std::uint32_t> baud;   // overrides the capture header
    std::optional<LineSettings> format;  // data/parity/stop bits; overrides the header
    Nanos timeout = kNanosPerSecond;
    const ProtocolRules* rules = &standard_rules();
};

// What a sink is told before the first record.
struct SessionInfo {
    SourceInfo source;
    LineSettings line;  // in effect after header and options
};

// Counts for the closing summary.
struct Totals {
    std::uint64_t records = 0;
    std::uint64_t requests = 0;
    std::uint64_t responses = 0;
    std::uint64_t exceptions = 0;
    std::uint64_t broadcasts = 0;
    std::uint64_t unknown = 0;
    std::uint64_t invalid = 0;
    std::uint64_t crc_bad = 0;
    std::uint64_t crc_swapped = 0;
    std::uint64_t unanswered = 0;
    std::uint64_t unsolicited = 0;
    std::uint64_t noise_runs = 0;
    std::uint64_t noise_bytes = 0;
    std::uint64_t bytes = 0;
};

class RecordSink {
  public:
    virtual ~RecordSink() = default;
    virtual void begin(const SessionInfo& session) = 0;
    virtual void record(const Record& record) = 0;
    // `remarks`: what the source wants the user told (e.g. skipped lines).
    virtual void end(const Totals& totals, const std::vector<std::string>& remarks) = 0;
};

// Decodes everything the source delivers into the sink. On a source error, everything
// read before it is still decoded and delivered, then the error is returned.
Status run_pipeline(ChunkSource& source, const PipelineOptions& options, RecordSink& sink);

// The decoder stage for one record (exposed for tests).
void decode_record(Record& record);

}  // namespace rtuscope
