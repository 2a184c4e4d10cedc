// The whole pipeline, source to sink: what `decode` and `sniff` run.
//   source --chunks--> framer --frames--> transactions --records--> decoder --> sink
#pragma once

#include <atomic>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "framing/functions.hpp"
#include "framing/line_settings.hpp"
#include "input/chunk.hpp"
#include "pairing/transactions.hpp"
#include "profiles/bus.hpp"
#include "util/result.hpp"

namespace rtuscope {

struct PipelineOptions {
    std::optional<std::uint32_t> baud;   // overrides the capture header
    std::optional<LineSettings> format;  // data/parity/stop bits; overrides the header
    Nanos timeout = kNanosPerSecond;
    const Bus* bus = nullptr;  // which slave is which device; none: standard decoding only
    bool guess = false;        // --guess: readings of the registers no profile covers
    // Live input (a tty): every record is flushed to the sink's output as soon as it is
    // decided, and what is buffered is decided once the line has been quiet for t3.5
    // plus this margin. The margin covers USB adapters, which hand over bytes in batches
    // up to 16 ms apart even while a frame is still arriving.
    bool live = false;
    Nanos idle_margin = 20'000'000;
    // Set (by a signal handler) to stop the run at the next record boundary, as if the
    // input ended there; read errors after it (an interrupted read) are the stop, too.
    const std::atomic<bool>* stop = nullptr;
    // A file is read ahead until its batching is learned (256 chunks) before its first
    // frame is decided; a replay paced to its own clock reads ahead at most this much of
    // its time, so that it starts at once.
    std::optional<Nanos> read_ahead_time;
};

// What a sink is told before the first record.
// Where the baud rate in effect comes from: the input (a capture header, a live port),
// --baud, the bus file or the devices' profiles, or nowhere (9600 assumed).
enum class BaudOrigin : std::uint8_t { input, option, profiles, assumed };

struct SessionInfo {
    SourceInfo source;
    LineSettings line;    // in effect after header and options
    BaudOrigin baud_origin = BaudOrigin::assumed;
    std::string devices;  // the bus map, "zb-uvi485 on 1, 2; pdu485 on 3"; empty without
    // How the input batches its bytes when that hides silences (framing/batching.hpp):
    // "chunks every 16 ms: silences under 16 ms cannot be seen"; empty otherwise.
    std::string batching;
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
    // Bytes of the frame in progress when a run was stopped (--seconds, a signal, the end
    // of a live stream): noted frame.cut_by_stop, counted here and not as an error.
    std::uint64_t cut_by_stop_bytes = 0;
    // What the user should be told at the end: the source's remarks (skipped lines), and
    // what looks wrong about the input (not Modbus RTU at these settings, a faster line).
    std::vector<std::string> remarks;
};

// Counts `record` into `totals`, as the pipeline does for the closing summary.
void count_record(Totals& totals, const Record& record);

class RecordSink {
  public:
    virtual ~RecordSink() = default;
    virtual void begin(const SessionInfo& session) = 0;
    virtual void record(const Record& record) = 0;
    // `remarks`: what the source wants the user told (e.g. skipped lines).
    virtual void end(const Totals& totals, const std::vector<std::string>& remarks) = 0;
    // Live output: push what has been written to its reader now.
    virtual void flush() {}
    // A live or paced source said that nothing came until `now` (an empty chunk): a
    // display refreshes its ages and reads its keys.
    virtual void idle(Nanos /*now*/) {}
};

// Decodes everything the source delivers into the sink. On a source error, everything
// read before it is still decoded and delivered, then the error is returned. A live run
// and a run stopped by `options.stop` end with the frame in progress noted as cut by the
// stop, not as broken on the line. A chunk
// with no bytes but a time is a live source saying that nothing came until then.
// `totals`, when given, receives the closing counts.
Status run_pipeline(ChunkSource& source, const PipelineOptions& options, RecordSink& sink,
                    Totals* totals = nullptr);

}  // namespace rtuscope
