#include "util/output_file.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace rtuscope {
namespace {

bool ends_with(std::string_view text, std::string_view end) {
    return text.size() >= end.size() && text.substr(text.size() - end.size()) == end;
}

// Every write() of the whole text, retried on EINTR.
Status write_all(int fd, std::string_view bytes, const std::string& path) {
    std::size_t done = 0;
    while (done < bytes.size()) {
        const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
        if (n < 0) {
            if (errno == EINTR) continue;
            return Error{fmt::format("cannot write the file: {}", std::strerror(errno)), path};
        }
        done += static_cast<std::size_t>(n);
    }
    return ok_status();
}

class PlainFile final : public OutputFile {
  public:
    PlainFile(std::string path, int fd) : OutputFile(std::move(path)), fd_(fd) {}
    ~PlainFile() override {
        if (fd_ >= 0) ::close(fd_);
    }
    PlainFile(const PlainFile&) = delete;
    PlainFile& operator=(const PlainFile&) = delete;

    Status write(std::string_view bytes) override {
        Status s = write_all(fd_, bytes, path());
        if (s) written_ += bytes.size();
        return s;
    }
    Status tick() override { return ok_status(); }
    Status close() override {
        if (fd_ < 0) return ok_status();
        const int fd = fd_;
        fd_ = -1;
        if (::close(fd) != 0) {
            return Error{fmt::format("cannot write the file: {}", std::strerror(errno)), path()};
        }
        return ok_status();
    }
    [[nodiscard]] std::uint64_t size() const override { return written_; }
    [[nodiscard]] std::uint64_t bytes_in() const override { return written_; }

  private:
    int fd_;
    std::uint64_t written_ = 0;
};

}  // namespace

Compression compression_for(std::string_view path) {
    if (ends_with(path, ".gz")) return Compression::gzip;
    if (ends_with(path, ".zst")) return Compression::zstd;
    return Compression::none;
}

Result<std::unique_ptr<OutputFile>> create_output_file(const std::string& path,
                                                       const OutputFileOptions& options) {
    if (options.compression != Compression::none) {
        return Error{"compressed output is not available in this build", path};
    }
    const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd < 0) return Error{fmt::format("cannot create the file: {}", std::strerror(errno)), path};
    return std::unique_ptr<OutputFile>(new PlainFile(path, fd));
}

}  // namespace rtuscope
