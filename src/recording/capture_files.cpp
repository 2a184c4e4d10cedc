#include "recording/capture_files.hpp"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

namespace rtuscope {

std::string stamped_name(std::string_view path, Nanos time) {
    const std::int64_t seconds = floor_div(has_time(time) ? time : 0, kNanosPerSecond);
    const std::int64_t day = floor_div(seconds, 86'400);
    const std::int64_t second_of_day = seconds - day * 86'400;
    const CivilDate date = civil_from_days(day);
    const std::string stamp =
        fmt::format("-{:04}{:02}{:02}T{:02}{:02}{:02}Z", date.year, date.month, date.day,
                    second_of_day / 3600, second_of_day / 60 % 60, second_of_day % 60);
    const std::size_t name_at = path.rfind('/') == std::string_view::npos ? 0 : path.rfind('/') + 1;
    const std::size_t dot = path.find('.', name_at + 1);  // a leading dot is part of the name
    const std::size_t at = dot == std::string_view::npos ? path.size() : dot;
    std::string name(path.substr(0, at));
    name += stamp;
    name += path.substr(at);
    return name;
}

CaptureFiles::CaptureFiles(std::string path, std::string header, const RotationOptions& rotation,
                           const OutputFileOptions& file)
    : path_(std::move(path)),
      header_(std::move(header)),
      rotation_(rotation),
      file_options_(file) {}

CaptureFiles::~CaptureFiles() = default;

std::string CaptureFiles::unused_name(Nanos time) {
    if (!rotation_.stamps()) return path_;
    std::string name = stamped_name(path_, time);
    const auto used = [&](const std::string& candidate) {
        return candidate == current_ || std::find(kept_.begin(), kept_.end(), candidate) != kept_.end();
    };
    if (!used(name)) return name;
    // After the stamp: "bus-20261128T030000Z_002.rtucap", which sorts after
    // "bus-20261128T030000Z.rtucap" ('_' after '.') and before the next second's.
    const std::string stamped = stamped_name("", time);
    const std::size_t stamp_end = name.find(stamped) + stamped.size();
    for (int n = 2;; ++n) {
        std::string candidate = name;
        candidate.insert(stamp_end, fmt::format("_{:03}", n));
        if (!used(candidate)) return candidate;
    }
}

Status CaptureFiles::start(Nanos time) {
    // A new file is what SIGUSR1 asks for: one that starts for another reason (a trigger
    // window) answers it too.
    if (rotation_.rotate_now != nullptr) rotation_.rotate_now->store(false);
    const std::string name = unused_name(time);
    if (file_) {
        if (Status s = file_->write(fmt::format("# continued in {}\n", name)); !s) return s;
        if (Status s = file_->close(); !s) return s;
        file_.reset();
    }
    auto created = create_output_file(name, file_options_);
    if (!created) return created.error();
    file_ = std::move(*created);
    std::string head = header_;
    if (files_started_ > 0) head += fmt::format("# continues {}\n", current_);
    if (Status s = file_->write(head); !s) return s;
    if (Status s = file_->end_block(); !s) return s;
    current_ = name;
    ++files_started_;
    data_bytes_ = 0;
    if (rotation_.period > 0 && has_time(time)) {
        next_boundary_ = (floor_div(time, rotation_.period) + 1) * rotation_.period;
    }
    kept_.push_back(name);
    return remove_beyond_kept();
}

Status CaptureFiles::remove_beyond_kept() {
    if (rotation_.keep_files == 0) return ok_status();
    while (kept_.size() > rotation_.keep_files) {
        const std::string oldest = kept_.front();
        kept_.pop_front();
        if (::unlink(oldest.c_str()) != 0 && errno != ENOENT) {
            return Error{fmt::format("cannot remove the oldest capture file (--rotate-files): {}",
                                     std::strerror(errno)),
                         oldest};
        }
    }
    return ok_status();
}

bool CaptureFiles::rotation_due(Nanos time, std::size_t adding) {
    if (rotation_.rotate_now != nullptr && rotation_.rotate_now->exchange(false)) return true;
    if (rotation_.period > 0 && has_time(time) && has_time(next_boundary_) &&
        time >= next_boundary_) {
        return true;
    }
    if (rotation_.max_bytes == 0 || data_bytes_ == 0) return false;
    // A file holds at least one line, however long, so that a line longer than the
    // limit does not start a file per line with nothing in them. A compressed file's
    // size is known once its blocks end: it may pass the limit by a block.
    if (file_options_.compression != Compression::none) return file_->size() >= rotation_.max_bytes;
    // Room is kept for the line naming the next file.
    const std::size_t last_line = std::string_view("# continued in \n").size() + path_.size() +
                                  stamped_name("", 0).size() + 8;
    return file_->bytes_in() + adding + last_line > rotation_.max_bytes;
}

Status CaptureFiles::write(std::string_view line, Nanos time) {
    if (!file_ || rotation_due(time, line.size())) {
        // A file by the clock is named after its interval's start: the names read as the
        // intervals they hold.
        Nanos start_time = time;
        if (file_ && rotation_.period > 0 && has_time(time)) {
            start_time = floor_div(time, rotation_.period) * rotation_.period;
        }
        if (Status s = start(start_time); !s) return s;
    }
    data_bytes_ += line.size();
    return file_->write(line);
}

Status CaptureFiles::comment(std::string_view line) {
    if (!file_) return ok_status();
    return file_->write(line);
}

Status CaptureFiles::idle(Nanos time) {
    if (!file_) return ok_status();
    if (rotation_due(time, 0)) {
        Nanos start_time = time;
        if (rotation_.period > 0 && has_time(time)) {
            start_time = floor_div(time, rotation_.period) * rotation_.period;
        }
        return start(start_time);
    }
    return file_->tick();
}

Status CaptureFiles::end(std::string_view last_line) {
    if (!file_) return ok_status();
    Status written = file_->write(last_line);
    Status closed = file_->close();
    file_.reset();
    if (!written) return written;
    return closed;
}

}  // namespace rtuscope
