#include "recording/recorder.hpp"

#include <fmt/format.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "input/capture_writer.hpp"

namespace rtuscope {
namespace {

constexpr std::string_view kStoppedLine = "# stopped (the live run ended here)\n";
constexpr std::string_view kWindowEndLine = "# stopped (the trigger window ends here)\n";

// The directory a file goes to can be written: checked before a run whose first file is
// made only when its first data comes.
Status check_directory(const std::string& path) {
    const std::size_t slash = path.rfind('/');
    const std::string directory =
        slash == std::string::npos ? "." : (slash == 0 ? "/" : path.substr(0, slash));
    if (::access(directory.c_str(), W_OK) != 0) {
        return Error{fmt::format("cannot create the capture: {}", std::strerror(errno)), path};
    }
    return ok_status();
}

}  // namespace

Recorder::Recorder(RecordingOptions options, std::string header)
    : options_(std::move(options)),
      files_(options_.path, std::move(header),
             [&] {
                 RotationOptions rotation = options_.rotation;
                 rotation.stamp_names = rotation.stamp_names || options_.windows.has_value();
                 return rotation;
             }(),
             options_.file) {}

Recorder::~Recorder() = default;

Status Recorder::open(Nanos now) {
    // A file named after its first data waits for it.
    if (options_.windows || options_.rotation.stamps()) return check_directory(options_.path);
    return files_.start(now);
}

Status Recorder::chunk(const Chunk& chunk) {
    if (deferred_) return *deferred_;
    if (has_time(chunk.time)) now_ = chunk.time;
    if (has_time(chunk.gap_since)) {
        if (Status s = files_.comment(capture_gap_line(chunk.gap_since, chunk.time)); !s) return s;
    }
    if (!options_.windows) {
        if (chunk.bytes.empty()) return files_.idle(chunk.time);
        return files_.write(capture_line(chunk), chunk.time);
    }
    if (chunk.bytes.empty()) {
        trim_held(now_);
        if (in_window_ && has_time(now_) &&
            now_ > window_end_ + options_.windows->decision_delay) {
            return end_window();
        }
        return files_.idle(chunk.time);
    }
    return held_chunk(chunk);
}

Status Recorder::held_chunk(const Chunk& chunk) {
    const TriggerWindows& w = *options_.windows;
    if (in_window_ && (!has_time(chunk.time) || chunk.time <= window_end_ || tail_pending_)) {
        return write_in_window(capture_line(chunk), chunk.time);
    }
    if (in_window_ && chunk.time > window_end_ + w.decision_delay) {
        if (Status s = end_window(); !s) return s;
    }
    // Past the window's end, or no window: held, for a window to come (or for a late
    // event to extend the open one).
    Held& held = held_.emplace_back();
    held.time = chunk.time;
    held.line = capture_line(chunk);
    held_bytes_ += held.line.size();
    trim_held(now_);
    return ok_status();
}

Status Recorder::write_in_window(std::string_view line, Nanos time) {
    // The first chunk that ends past the window's end holds its last frame's end.
    if (has_time(time) && time > window_end_) tail_pending_ = false;
    if (has_time(time)) last_written_ = time;
    return files_.write(line, time);
}

void Recorder::trim_held(Nanos now) {
    const TriggerWindows& w = *options_.windows;
    while (!held_.empty() &&
           (held_bytes_ > w.pre_bytes ||
            (has_time(now) && has_time(held_.front().time) &&
             held_.front().time < now - w.pre - w.decision_delay))) {
        held_bytes_ -= held_.front().line.size();
        held_.pop_front();
    }
}

Status Recorder::end_window() {
    in_window_ = false;
    return files_.end(kWindowEndLine);
}

void Recorder::event(Nanos start, Nanos end, std::string_view what) {
    if (!options_.windows || deferred_) return;
    const TriggerWindows& w = *options_.windows;
    ++events_;
    const Nanos from = has_time(start) ? start - w.pre : kNoTime;
    const auto fail = [&](const Status& s) {
        if (!s) deferred_ = s.error();
        return !s;
    };
    // An event whose window does not reach back to the open one's end starts its own.
    if (in_window_ && has_time(from) && from > window_end_) {
        if (fail(end_window())) return;
    }
    if (!in_window_) {
        while (!held_.empty() && has_time(from) && has_time(held_.front().time) &&
               held_.front().time < from) {
            held_bytes_ -= held_.front().line.size();
            held_.pop_front();
        }
        const Nanos first = held_.empty() ? (has_time(from) ? from : now_) : held_.front().time;
        if (fail(files_.start(first))) return;
        in_window_ = true;
        window_end_ = kNoTime;
        last_written_ = kNoTime;
        ++windows_;
    }
    const Nanos last = has_time(end) ? end : (has_time(start) ? start : now_);
    if (has_time(last)) {
        window_end_ = has_time(window_end_) ? std::max(window_end_, last + w.post) : last + w.post;
    }
    tail_pending_ = !has_time(last_written_) || last_written_ <= window_end_;
    // The held chunks up to the window's end and the one past it; the later ones stay
    // held, as the chunks that come after them would be.
    while (!held_.empty() && (tail_pending_ || !has_time(held_.front().time) ||
                              held_.front().time <= window_end_)) {
        if (fail(write_in_window(held_.front().line, held_.front().time))) return;
        held_bytes_ -= held_.front().line.size();
        held_.pop_front();
    }
    fail(files_.comment(fmt::format("# event: {}\n", what)));
}

Status Recorder::finish() {
    if (deferred_) return *deferred_;
    if (options_.windows && !in_window_) return ok_status();
    return files_.end(kStoppedLine);
}

std::string recording_text(const RecordingCounts& counts, bool triggered) {
    std::string text = counts.files == 0
                           ? std::string("recording: no file yet")
                           : fmt::format("recording {} ({} {})", counts.last_file, counts.files,
                                         counts.files == 1 ? "file" : "files");
    if (triggered) {
        text += fmt::format("; {} trigger {}, {} {}", counts.events,
                            counts.events == 1 ? "event" : "events", counts.windows,
                            counts.windows == 1 ? "window" : "windows");
    }
    return text;
}

RecordingCounts Recorder::counts() const {
    return {events_, windows_, files_.files_started(), files_.current_name()};
}

namespace {

class RecordingSource final : public ChunkSource {
  public:
    RecordingSource(std::unique_ptr<ChunkSource> inner, std::shared_ptr<Recorder> recorder)
        : inner_(std::move(inner)), recorder_(std::move(recorder)) {}

    [[nodiscard]] const SourceInfo& info() const override { return inner_->info(); }
    [[nodiscard]] std::vector<std::string> remarks() const override { return inner_->remarks(); }

    Result<bool> next(Chunk& out) override {
        Result<bool> more = inner_->next(out);
        if (more.ok() && !*more && !ended_) {
            // The live run was stopped here: decoded later, a frame cut by the stop is
            // not taken for one the bus cut short.
            ended_ = true;
            if (Status s = recorder_->finish(); !s) return s.error();
        }
        if (!more.ok() || !*more) return more;
        if (Status s = recorder_->chunk(out); !s) return s.error();
        return more;
    }

  private:
    std::unique_ptr<ChunkSource> inner_;
    std::shared_ptr<Recorder> recorder_;
    bool ended_ = false;
};

}  // namespace

std::unique_ptr<ChunkSource> record_chunks(std::unique_ptr<ChunkSource> source,
                                           std::shared_ptr<Recorder> recorder) {
    return std::make_unique<RecordingSource>(std::move(source), std::move(recorder));
}

}  // namespace rtuscope

namespace rtuscope {

Result<std::unique_ptr<ChunkSource>> record_capture(std::unique_ptr<ChunkSource> source,
                                                    const std::string& path,
                                                    const SourceInfo& header) {
    RecordingOptions options;
    options.path = path;
    auto recorder = std::make_shared<Recorder>(options, capture_header(header));
    if (Status s = recorder->open(kNoTime); !s) return s.error();
    return record_chunks(std::move(source), std::move(recorder));
}

}  // namespace rtuscope
