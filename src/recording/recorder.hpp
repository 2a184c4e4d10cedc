// sniff -w: the raw chunks of a live line recorded in the native capture format (v1) as
// they pass, so that decoding the files later gives what the live run showed: all of
// them (rotated by CaptureFiles), or with triggers only the windows around events.
//
// Triggered recording keeps the line's recent chunks in memory (the `pre` seconds before
// now, at most `pre_bytes` of capture text) and writes nothing until an event: a record
// a trigger matched. Then a window file starts with the held chunks from `pre` before the
// event's frame, takes every chunk until `post` after the last event's frame and the
// one chunk after (which holds the frame's end when an adapter batched it with later
// bytes), and ends. Each chunk is written once: overlapping windows are one.
// An event comes to the recorder only once the record is decided (an unanswered request
// after the answer timeout), so the chunks are held `decision_delay` longer than `pre`,
// and a window stays open that much past its end in case a late event extends it.
#pragma once

#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "input/chunk.hpp"
#include "recording/capture_files.hpp"
#include "util/result.hpp"

namespace rtuscope {

struct TriggerWindows {
    Nanos pre = 10 * kNanosPerSecond;               // --pre
    std::size_t pre_bytes = std::size_t{64} << 20;  // --pre-bytes
    Nanos post = 10 * kNanosPerSecond;              // --post
    // How long after a frame its record can still become an event (the answer timeout
    // and the framer's silence).
    Nanos decision_delay = 2 * kNanosPerSecond;
};

struct RecordingOptions {
    std::string path;  // -w
    RotationOptions rotation;
    OutputFileOptions file;  // compression from the name's extension
    std::optional<TriggerWindows> windows;  // --trigger: only windows around events
};

struct RecordingCounts {
    std::uint64_t events = 0;
    std::uint64_t windows = 0;
    std::uint64_t files = 0;
    std::string last_file;
};

// "recording bus-20261128T030000Z.rtucap (12 files)", and with triggers "; 3 trigger
// events, 2 windows": what watch shows and the run's summary says.
std::string recording_text(const RecordingCounts& counts, bool triggered);

class Recorder {
  public:
    // `header`: what the files' header says (capture_header()).
    Recorder(RecordingOptions options, std::string header);
    ~Recorder();
    Recorder(const Recorder&) = delete;
    Recorder& operator=(const Recorder&) = delete;

    // Starts the one file of a recording without triggers at once, so that a file that
    // cannot be created is an error before the run starts.
    Status open(Nanos now);
    // A chunk of the line, or an idle tick (no bytes).
    Status chunk(const Chunk& chunk);
    // A record a trigger matched: its frame's start and end, and what fired (a comment
    // in the window file).
    void event(Nanos start, Nanos end, std::string_view what);
    // The run ended: the open file ends with a `# stopped` line.
    Status finish();

    // The first error met by event(), which has no way to return one.
    [[nodiscard]] std::optional<Error> deferred_error() const { return deferred_; }
    [[nodiscard]] RecordingCounts counts() const;
    [[nodiscard]] bool triggered() const { return options_.windows.has_value(); }

  private:
    struct Held {
        Nanos time = kNoTime;
        std::string line;
    };
    Status held_chunk(const Chunk& chunk);
    Status write_in_window(std::string_view line, Nanos time);
    void trim_held(Nanos now);
    Status end_window();

    RecordingOptions options_;
    CaptureFiles files_;
    std::deque<Held> held_;
    std::size_t held_bytes_ = 0;
    bool in_window_ = false;
    Nanos window_end_ = kNoTime;  // `post` after the last event's frame
    // The chunk that ends past window_end_ is still to come: it holds the end of the
    // event's frame when an adapter delivered it with later bytes.
    bool tail_pending_ = false;
    Nanos last_written_ = kNoTime;
    Nanos now_ = kNoTime;
    std::uint64_t events_ = 0;
    std::uint64_t windows_ = 0;
    std::optional<Error> deferred_;
};

}  // namespace rtuscope

namespace rtuscope {

// Wraps `source`: every chunk it delivers goes to `recorder` before it is handed on, and
// its end ends the recording. A write error ends the run with that error.
std::unique_ptr<ChunkSource> record_chunks(std::unique_ptr<ChunkSource> source,
                                           std::shared_ptr<Recorder> recorder);

}  // namespace rtuscope

namespace rtuscope {

// The plainest recording: every chunk of `source` into the one file `path`, whose header
// says what `header` holds; the file is created at once (an error names it).
Result<std::unique_ptr<ChunkSource>> record_capture(std::unique_ptr<ChunkSource> source,
                                                    const std::string& path,
                                                    const SourceInfo& header);

}  // namespace rtuscope
