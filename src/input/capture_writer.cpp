#include "input/capture_writer.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "util/text.hpp"

namespace rtuscope {

std::string capture_line(const Chunk& chunk) {
    // Untimed chunks never come from a tty; "0" still makes a line the reader accepts.
    std::string line = "0";
    if (has_time(chunk.time)) {
        const bool negative = chunk.time < 0;
        const auto magnitude =
            static_cast<std::uint64_t>(negative ? -(chunk.time + 1) + 1 : chunk.time);
        line = fmt::format("{}{}.{:09}", negative ? "-" : "", magnitude / 1'000'000'000U,
                           magnitude % 1'000'000'000U);
    }
    if (!chunk.channel.empty()) line += " @" + chunk.channel;
    line += ' ';
    append_hex(line, chunk.bytes, true);
    line += '\n';
    return line;
}

namespace {

Status write_all(int fd, const std::string& text, const std::string& path) {
    std::size_t done = 0;
    while (done < text.size()) {
        const ssize_t n = write(fd, text.data() + done, text.size() - done);
        if (n < 0) {
            if (errno == EINTR) continue;
            return Error{fmt::format("cannot write the capture: {}", std::strerror(errno)), path};
        }
        done += static_cast<std::size_t>(n);
    }
    return ok_status();
}

class RecordingSource final : public ChunkSource {
  public:
    RecordingSource(std::unique_ptr<ChunkSource> inner, int fd, std::string path)
        : inner_(std::move(inner)), fd_(fd), path_(std::move(path)) {}
    ~RecordingSource() override { close(fd_); }
    RecordingSource(const RecordingSource&) = delete;
    RecordingSource& operator=(const RecordingSource&) = delete;

    [[nodiscard]] const SourceInfo& info() const override { return inner_->info(); }
    [[nodiscard]] std::vector<std::string> remarks() const override { return inner_->remarks(); }

    Result<bool> next(Chunk& out) override {
        Result<bool> more = inner_->next(out);
        if (!more.ok() || !*more || out.bytes.empty()) return more;
        if (Status s = write_all(fd_, capture_line(out), path_); !s) return s.error();
        return more;
    }

  private:
    std::unique_ptr<ChunkSource> inner_;
    int fd_;
    std::string path_;
};

}  // namespace

std::string capture_header(const std::optional<LineSettings>& line) {
    std::string header = "# rtuscope capture v1\n";
    if (line) header += fmt::format("# serial {} {}\n", line->baud, line->format());
    return header;
}

Result<std::unique_ptr<ChunkSource>> record_capture(std::unique_ptr<ChunkSource> source,
                                                    const std::string& path) {
    const int fd = open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd < 0) {
        return Error{fmt::format("cannot create the capture: {}", std::strerror(errno)), path};
    }
    const SourceInfo& info = source->info();
    std::string header = capture_header(info.line);
    header += fmt::format("# recorded live from {}\n", info.name);
    if (Status s = write_all(fd, header, path); !s) {
        close(fd);
        return s.error();
    }
    return std::unique_ptr<ChunkSource>(new RecordingSource(std::move(source), fd, path));
}

}  // namespace rtuscope
