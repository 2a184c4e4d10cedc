// The capture files of one recording (sniff -w): each file self-contained (the capture
// header with the line settings, the device map and the program), rotated by size or by
// the clock, the oldest removed beyond a count, as tcpdump's -C, -G and -W do.
//
// Names: without rotation or triggers, the file is -w's path. Otherwise each file is
// named after the UTC time of its first data: "bus.rtucap" gives
// "bus-20261128T030000Z.rtucap" (the stamp goes before the first dot of the name, so
// "bus.rtucap.zst" gives "bus-20261128T030000Z.rtucap.zst"); a second file starting in
// the same second gets "_002", "_003" after the stamp. The names sort in time order, as
// the shell and `decode 'bus-*.rtucap'` list them.
//
// A file that ends by rotation says so in its last line, `# continued in NAME`, and the
// next one in the line after its header, `# continues NAME`: decoded alone, a frame cut
// at the boundary is known to be cut by the rotation (as by `# stopped`); decoded
// together (`decode 'bus-*.rtucap'`), the frame is whole again.
#pragma once

#include <atomic>
#include <cstdint>
#include <deque>
#include <memory>
#include <string>
#include <string_view>

#include "util/output_file.hpp"
#include "util/result.hpp"
#include "util/time.hpp"

namespace rtuscope {

struct RotationOptions {
    // --rotate-size: a file ends before it grows past this (a compressed one may pass it
    // by a block); 0: no
    std::uint64_t max_bytes = 0;
    Nanos period = 0;             // --rotate-seconds: files end on multiples of it (UTC); 0: no
    std::size_t keep_files = 0;   // --rotate-files: only the newest this many are kept; 0: all
    // Stamp the names even without rotation (trigger windows: a file each).
    bool stamp_names = false;
    // Set from elsewhere (SIGUSR1): the next write or idle tick starts a new file.
    std::atomic<bool>* rotate_now = nullptr;

    [[nodiscard]] bool stamps() const {
        return stamp_names || max_bytes != 0 || period != 0 || keep_files != 0;
    }
};

// "bus.rtucap" and a time: "bus-20261128T030000Z.rtucap" (see above).
std::string stamped_name(std::string_view path, Nanos time);

class CaptureFiles {
  public:
    // `header`: the capture header every file starts with (capture_header()).
    CaptureFiles(std::string path, std::string header, const RotationOptions& rotation,
                 const OutputFileOptions& file);
    ~CaptureFiles();
    CaptureFiles(const CaptureFiles&) = delete;
    CaptureFiles& operator=(const CaptureFiles&) = delete;

    // Starts a file whose first data is at `time` (the header written). A file still open
    // is ended first, with `# continued in NAME`.
    Status start(Nanos time);
    // A data line at `time`: into the open file, a new one first when rotation is due (or
    // when none is open).
    Status write(std::string_view line, Nanos time);
    // A comment line into the open file, if any; never rotates.
    Status comment(std::string_view line);
    // Nothing came until `time`: rotation by the clock and the compressed block's flush
    // happen on a quiet line too.
    Status idle(Nanos time);
    // Ends the open file with `last_line` (e.g. `# stopped ...`), if one is open.
    Status end(std::string_view last_line);

    [[nodiscard]] bool is_open() const { return file_ != nullptr; }
    [[nodiscard]] std::uint64_t files_started() const { return files_started_; }
    // The open file's name, or the last one's; empty before the first.
    [[nodiscard]] const std::string& current_name() const { return current_; }

  private:
    [[nodiscard]] bool rotation_due(Nanos time, std::size_t adding);
    Status remove_beyond_kept();
    std::string unused_name(Nanos time);

    std::string path_;
    std::string header_;
    RotationOptions rotation_;
    OutputFileOptions file_options_;
    std::unique_ptr<OutputFile> file_;
    std::uint64_t data_bytes_ = 0;  // data lines in the open file (the header not counted)
    Nanos next_boundary_ = kNoTime;
    std::uint64_t files_started_ = 0;
    std::string current_;
    std::deque<std::string> kept_;  // the files of this run still on disk, oldest first
};

}  // namespace rtuscope
