#include "input/capture_writer.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <string_view>

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

constexpr std::string_view kStoppedLine = "# stopped (the live run ended here)\n";

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
        if (more.ok() && !*more && !ended_) {
            // The live run was stopped here: decoded later, a frame cut by the stop is
            // not taken for one the bus cut short.
            ended_ = true;
            if (Status s = write_all(fd_, std::string(kStoppedLine), path_); !s) return s.error();
        }
        if (!more.ok() || !*more || out.bytes.empty()) return more;
        if (Status s = write_all(fd_, capture_line(out), path_); !s) return s.error();
        return more;
    }

  private:
    std::unique_ptr<ChunkSource> inner_;
    int fd_;
    std::string path_;
    bool ended_ = false;
};

}  // namespace

std::string capture_header(const SourceInfo& header) {
    std::string text = "# rtuscope capture v1\n";
    if (header.line)
        text += fmt::format("# serial {} {}\n", header.line->baud, header.line->format());
    if (!header.written_by.empty()) text += fmt::format("# written by {}\n", header.written_by);
    for (const auto& [address, profile] : header.devices) {
        text += fmt::format("# device {} {}\n", address, profile);
    }
    for (const auto& [name, toml] : header.embedded_profiles) {
        text += fmt::format("# profile {}\n", name);
        std::string_view rest = toml;
        while (!rest.empty()) {
            const std::size_t end = std::min(rest.find('\n'), rest.size());
            text += "#| ";
            text += rest.substr(0, end);
            text += '\n';
            rest.remove_prefix(std::min(end + 1, rest.size()));
        }
        text += "# end profile\n";
    }
    if (!header.name.empty()) text += fmt::format("# recorded live from {}\n", header.name);
    return text;
}

Result<std::unique_ptr<ChunkSource>> record_capture(std::unique_ptr<ChunkSource> source,
                                                    const std::string& path,
                                                    const SourceInfo& header) {
    const int fd = open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd < 0) {
        return Error{fmt::format("cannot create the capture: {}", std::strerror(errno)), path};
    }
    if (Status s = write_all(fd, capture_header(header), path); !s) {
        close(fd);
        return s.error();
    }
    return std::unique_ptr<ChunkSource>(new RecordingSource(std::move(source), fd, path));
}

}  // namespace rtuscope
