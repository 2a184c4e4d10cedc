// Finding an unknown line's settings by listening: the bytes heard at each candidate
// baud rate and character format are framed and paired as `decode` would, and scored by
// what a right setting gives and a wrong one does not: frames with a valid CRC covering
// the bytes, answers paired with requests, no parity or framing errors where the port
// reports them, and byte spacing that fits the character length where reads are timed
// finely enough. Settings that read the line alike are reported together.
//
//   listener --chunks per setting--> score_setting --> rank --> DetectResult
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "framing/char_time.hpp"
#include "framing/line_settings.hpp"
#include "input/chunk.hpp"
#include "util/result.hpp"
#include "util/time.hpp"

namespace rtuscope {

// How the spacing of bytes heard at a setting fits its character length.
enum class TimingFit : std::uint8_t {
    unknown,  // too few bytes timed one by one (a USB adapter's batches)
    exact,    // one character apart
    slower,   // further apart: this format, with pauses between characters, or a longer one
    faster,   // closer than a character of this format lasts: not this format
};

struct SettingScore {
    LineSettings line;
    Nanos listened = 0;
    std::uint64_t bytes = 0;
    std::uint64_t frames = 0;        // frames with a valid CRC
    std::uint64_t frame_bytes = 0;   // their bytes
    std::uint64_t paired = 0;        // answers paired with their request
    std::uint64_t bad_frames = 0;    // bad CRC or cut short
    std::uint64_t char_errors = 0;   // bytes the port received with a parity or framing error
    // A listen's first and last records when they are pieces of frames that its start and
    // end cut (before the first and after the last valid frame, up to a frame's bytes at
    // each end): their bytes are not judged.
    std::uint64_t edge_bytes = 0;
    std::optional<CharTimeEstimate> timing;
    TimingFit timing_fit = TimingFit::unknown;
    double score = 0;  // 0-100

    [[nodiscard]] double coverage() const;  // share of the bytes in valid frames
};

// Frames and pairs `chunks` (one setting's, in time order) at `line` and scores them,
// without the first and last bursts of bytes where there are more (pieces of frames cut
// by the start and end of listening).
// A recording read whole (`whole` true) keeps its first and last bursts.
SettingScore score_setting(const LineSettings& line, std::span<const Chunk> chunks,
                           Nanos listened, bool whole = false);

// The formats tried by default, and with --all-formats.
std::vector<LineSettings> default_formats(bool all_formats);
// The rates tried by default, the common ones first.
std::vector<std::uint32_t> default_bauds();

struct DetectOptions {
    std::vector<std::uint32_t> bauds = default_bauds();  // in the order tried
    std::vector<LineSettings> formats = default_formats(false);  // their baud is ignored
    Nanos max_total = 120 * kNanosPerSecond;  // --max-seconds
    Nanos min_dwell = 500'000'000;  // at a setting, at least
    Nanos max_dwell = 8 * kNanosPerSecond;  // at a setting, at most, when the line is busy
    // How long the first setting waits for the line's first byte.
    Nanos quiet_wait = 30 * kNanosPerSecond;
    const std::atomic<bool>* stop = nullptr;
};

// Listens at `line` for at most `most`, or until `enough` says so; appends what it heard
// to `out` and returns how long it listened.
using Listen = std::function<Result<Nanos>(
    const LineSettings& line, Nanos most,
    const std::function<bool(std::span<const Chunk>, Nanos)>& enough, std::vector<Chunk>& out)>;

struct DetectResult {
    std::vector<SettingScore> ranked;  // best first
    std::size_t alike = 0;     // how many at the top read the line alike (0: nothing found)
    LineSettings chosen;       // the one to use among them
    std::string confidence;    // "high", "medium", "low"
    bool quiet = false;        // nothing was heard at all
    bool cut_short = false;    // --max-seconds or a stop ended it before every setting
    bool interrupted = false;  // a stop (a signal) did
    Nanos listened = 0;
    bool errors_reported = false;  // the port marked parity or framing errors somewhere
};

// Tries the settings in turn: every rate at the first format until one reads the line
// well, then the other formats at that rate; every format at every rate when none does.
Result<DetectResult> detect_line(const Listen& listen, const DetectOptions& options);

// The verdict and why, a line each (no line ends): the best setting, those that read the
// line alike, a run cut short; or that the line is quiet or nothing reads it.
std::vector<std::string> detect_verdict(const DetectResult& result);
// The ranked settings as a table, then the verdict, for the terminal.
std::string format_detect_result(const DetectResult& result);
// "3 answers paired with their requests"
std::string answers_paired(std::uint64_t paired);
// "--baud 19200 --format 8E1"
std::string line_options(const LineSettings& line);

}  // namespace rtuscope
