// One setting's evidence: what `decode` makes of the bytes heard at it.
#include <algorithm>
#include <cmath>

#include "detect/detect.hpp"
#include "framing/functions.hpp"
#include "pipeline.hpp"

namespace rtuscope {
namespace {

// The chunks heard at one setting, as a source for the pipeline.
class HeardSource final : public ChunkSource {
  public:
    HeardSource(std::span<const Chunk> chunks, const LineSettings& line) : chunks_(chunks) {
        info_.name = "heard";
        info_.format = "live";
        info_.line = line;
        info_.timed = true;
    }
    [[nodiscard]] const SourceInfo& info() const override { return info_; }
    Result<bool> next(Chunk& out) override {
        if (next_ == chunks_.size()) return false;
        out = chunks_[next_++];
        return true;
    }

  private:
    std::span<const Chunk> chunks_;
    std::size_t next_ = 0;
    SourceInfo info_;
};

class Counting final : public RecordSink {
  public:
    explicit Counting(SettingScore& score) : score_(score) {}
    void begin(const SessionInfo& /*session*/) override {}
    void record(const Record& r) override {
        const CrcStatus crc = r.frame.crc.status;
        const bool valid = r.kind != Kind::noise && r.kind != Kind::invalid &&
                           crc != CrcStatus::bad && crc != CrcStatus::none;
        // Bytes outside valid frames before the first and since the last.
        std::uint64_t& edge = score_.frames == 0 ? leading_ : trailing_;
        if (!valid) {
            edge += r.frame.bytes.size();
        } else {
            trailing_ = 0;
        }
        if (r.kind == Kind::noise) return;
        if (!valid) {
            ++score_.bad_frames;
            return;
        }
        ++score_.frames;
        score_.frame_bytes += r.frame.bytes.size();
        if ((r.kind == Kind::response || r.kind == Kind::exception) && r.request_number != 0) {
            ++score_.paired;
        }
    }
    void end(const Totals& /*totals*/, const std::vector<std::string>& /*remarks*/) override {}

    // Bytes of the first and last records that are pieces of frames: the records before
    // the first and after the last valid frame, no more than a frame's bytes together
    // (a reader woken late more than once parts one frame into several), among enough
    // valid frames that chance did not make them.
    [[nodiscard]] std::uint64_t edge_bytes() const {
        if (score_.frames < 3) return 0;
        const auto piece = [](std::uint64_t bytes) {
            return bytes <= kMaxAdu ? bytes : std::uint64_t{0};
        };
        return piece(leading_) + piece(trailing_);
    }

  private:
    SettingScore& score_;
    std::uint64_t leading_ = 0;
    std::uint64_t trailing_ = 0;
};

TimingFit timing_fit(const LineSettings& line, const std::optional<CharTimeEstimate>& timing) {
    if (!timing) return TimingFit::unknown;
    // Within half a bit of the format's length: a reader's jitter at high rates is a few
    // per cent of a character.
    const double bits = static_cast<double>(timing->char_time) * line.baud / kNanosPerSecond;
    const double length = line.bits_per_char();
    if (std::abs(bits - length) <= 0.5) return TimingFit::exact;
    if (bits < length) return TimingFit::faster;
    // Spacing beyond the longest character (12 bits) is the reader's, not the line's: a
    // port read every few characters.
    return bits <= 12.5 ? TimingFit::slower : TimingFit::unknown;
}

}  // namespace

double SettingScore::coverage() const {
    const std::uint64_t judged = bytes - edge_bytes;
    return judged == 0 ? 0.0 : static_cast<double>(frame_bytes) / static_cast<double>(judged);
}

// Listening starts and stops at moments that have nothing to do with the line: the first
// and last bursts of bytes may be pieces of frames. Where there are more, they are left
// out, so that settings heard at different moments compare on whole frames.
std::span<const Chunk> whole_bursts(const LineSettings& line, std::span<const Chunk> chunks) {
    std::vector<std::size_t> starts;  // the chunks that follow a silence
    for (std::size_t i = 1; i < chunks.size(); ++i) {
        if (has_time(chunks[i].time) && has_time(chunks[i - 1].time) &&
            chunks[i].time - chunks[i - 1].time > line.t35()) {
            starts.push_back(i);
        }
    }
    if (starts.size() < 3) return chunks;
    return chunks.subspan(starts.front(), starts.back() - starts.front());
}

SettingScore score_setting(const LineSettings& line, std::span<const Chunk> heard,
                           Nanos listened, bool whole) {
    const std::span<const Chunk> chunks = whole ? heard : whole_bursts(line, heard);
    SettingScore s;
    s.line = line;
    s.listened = listened;
    CharTimeEstimator estimator;
    for (const Chunk& c : chunks) {
        s.bytes += c.bytes.size();
        s.char_errors += c.char_errors.size();
        estimator.chunk(c);
    }
    s.timing = estimator.estimate();
    s.timing_fit = timing_fit(line, s.timing);
    if (s.bytes == 0) return s;

    HeardSource source(chunks, line);
    PipelineOptions options;
    options.baud = line.baud;
    options.format = line;
    Counting counting(s);
    // Heard bytes always make records: a source in memory has no read error to give.
    (void)run_pipeline(source, options, counting);
    // Where a loaded machine reads a port late, a frame's bytes seem to part at a silence
    // and the bursts left out above may not be whole frames.
    if (!whole) s.edge_bytes = counting.edge_bytes();

    // A right setting puts the bytes in frames with a valid CRC, without errors, at the
    // spacing of its characters; a wrong one gives noise and errors. A few frames, or
    // fewer answering requests, are needed before any of it counts: a CRC matches by
    // chance once in 65536 tries, a pair far less often. How many answers came within the
    // time listened depends on the moment, not on the setting, so beyond that it does not
    // rank settings.
    const double coverage = std::min(1.0, s.coverage());
    const double clean =
        1.0 - std::min(1.0, static_cast<double>(s.char_errors) / static_cast<double>(s.bytes));
    const double evidence = std::min(1.0, static_cast<double>(s.frames + s.paired) / 3.0);
    double timing = 1.0;
    if (s.timing_fit == TimingFit::slower) timing = 0.9;
    if (s.timing_fit == TimingFit::faster) timing = 0.3;
    s.score = 100.0 * coverage * clean * evidence * timing;
    return s;
}

}  // namespace rtuscope
