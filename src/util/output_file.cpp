#include "util/output_file.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <unistd.h>
#include <zlib.h>
#include <zstd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <optional>

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
    Status end_block() override { return ok_status(); }
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

// A block is held twice (as written and compressed), and zlib counts its input in 32 bits.
constexpr std::size_t kMostBlockBytes = std::size_t{64} << 20;

// The libraries' default levels (zstd 3, zlib 6): a run writes at most what a serial line
// carries (115200 baud: some 40 KB/s of capture text), about a hundred times less than
// zlib's default compresses a second on a loaded core (zstd's, ten times more), and
// higher levels shrink the bench capture by 1 % (gzip -9) to 9 % (zstd -9) for 2 to 9
// times the CPU (docs/performance.md).

// Compresses a block into one complete gzip member or zstd frame.
class BlockCompressor {
  public:
    virtual ~BlockCompressor() = default;
    BlockCompressor() = default;
    BlockCompressor(const BlockCompressor&) = delete;
    BlockCompressor& operator=(const BlockCompressor&) = delete;
    // `out` becomes the member or frame of `block`.
    virtual Status compress(std::string_view block, std::string& out) = 0;
};

class ZstdCompressor final : public BlockCompressor {
  public:
    ZstdCompressor() : cctx_(ZSTD_createCCtx()) {
        if (cctx_ == nullptr) return;
        ZSTD_CCtx_setParameter(cctx_, ZSTD_c_compressionLevel, ZSTD_CLEVEL_DEFAULT);
        // Every frame carries its content's checksum: a block damaged on disk is an error
        // when read, not wrong bytes.
        ZSTD_CCtx_setParameter(cctx_, ZSTD_c_checksumFlag, 1);
    }
    ~ZstdCompressor() override { ZSTD_freeCCtx(cctx_); }
    ZstdCompressor(const ZstdCompressor&) = delete;
    ZstdCompressor& operator=(const ZstdCompressor&) = delete;

    [[nodiscard]] bool ready() const { return cctx_ != nullptr; }

    Status compress(std::string_view block, std::string& out) override {
        out.resize(ZSTD_compressBound(block.size()));
        const std::size_t n =
            ZSTD_compress2(cctx_, out.data(), out.size(), block.data(), block.size());
        if (ZSTD_isError(n) != 0) {
            return Error{fmt::format("cannot compress: {}", ZSTD_getErrorName(n))};
        }
        out.resize(n);
        return ok_status();
    }

  private:
    ZSTD_CCtx* cctx_;
};

class GzipCompressor final : public BlockCompressor {
  public:
    GzipCompressor() {
        // 15 + 16: a 32 KiB window inside a gzip header and trailer (CRC-32 and length).
        ready_ = deflateInit2(&z_, Z_DEFAULT_COMPRESSION, Z_DEFLATED, 15 + 16, 8,
                              Z_DEFAULT_STRATEGY) == Z_OK;
    }
    ~GzipCompressor() override {
        if (ready_) deflateEnd(&z_);
    }
    GzipCompressor(const GzipCompressor&) = delete;
    GzipCompressor& operator=(const GzipCompressor&) = delete;

    [[nodiscard]] bool ready() const { return ready_; }

    Status compress(std::string_view block, std::string& out) override {
        if (deflateReset(&z_) != Z_OK) return Error{"cannot compress: zlib refuses to reset"};
        out.resize(deflateBound(&z_, static_cast<uLong>(block.size())));
        // zlib's interface is not const-correct; it does not write its input.
        z_.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(block.data()));
        z_.avail_in = static_cast<uInt>(block.size());
        z_.next_out = reinterpret_cast<Bytef*>(out.data());
        z_.avail_out = static_cast<uInt>(out.size());
        const int rc = deflate(&z_, Z_FINISH);
        if (rc != Z_STREAM_END) {
            return Error{fmt::format("cannot compress: {}", z_.msg != nullptr ? z_.msg : "zlib")};
        }
        out.resize(z_.total_out);
        return ok_status();
    }

  private:
    z_stream z_{};
    bool ready_ = false;
};

// Blocks of the bytes written, each compressed on its own and written to the file with one
// write(2) as it ends: nothing waits in a buffer past the end of its block.
class BlockFile final : public OutputFile {
  public:
    BlockFile(std::string path, int fd, std::unique_ptr<BlockCompressor> compressor,
              const OutputFileOptions& options)
        : OutputFile(std::move(path)),
          fd_(fd),
          compressor_(std::move(compressor)),
          interval_(options.block_interval),
          block_bytes_(std::clamp<std::size_t>(options.block_bytes, 1, kMostBlockBytes)) {}
    ~BlockFile() override { (void)BlockFile::close(); }
    BlockFile(const BlockFile&) = delete;
    BlockFile& operator=(const BlockFile&) = delete;

    // A block ends between writes (before one that would take it past block_bytes), so
    // that what decodes of a file cut off ends where a write ended: a capture's whole
    // line. Only a write longer than kMostBlockBytes is cut.
    Status write(std::string_view bytes) override {
        if (failed_) return *failed_;
        if (fd_ < 0) return Error{"cannot write: the file is closed", path()};
        while (!bytes.empty()) {
            if (!block_.empty() && block_.size() + bytes.size() > block_bytes_) {
                if (Status s = end_block(); !s) return s;
            }
            if (block_.empty()) block_start_ = clock_ns(CLOCK_MONOTONIC);
            const std::size_t n = std::min(bytes.size(), kMostBlockBytes - block_.size());
            block_.append(bytes.substr(0, n));
            bytes_in_ += n;
            bytes.remove_prefix(n);
            if (block_.size() >= block_bytes_) {
                if (Status s = end_block(); !s) return s;
            }
        }
        return tick();
    }

    Status tick() override {
        if (failed_) return *failed_;
        if (block_.empty() || clock_ns(CLOCK_MONOTONIC) - block_start_ < interval_) {
            return ok_status();
        }
        return end_block();
    }

    Status close() override {
        if (fd_ < 0) return failed_ ? Status(*failed_) : ok_status();
        Status ended = failed_ ? Status(*failed_) : end_block();
        const int fd = fd_;
        fd_ = -1;
        if (::close(fd) != 0 && ended) {
            return Error{fmt::format("cannot write the file: {}", std::strerror(errno)), path()};
        }
        return ended;
    }

    [[nodiscard]] std::uint64_t size() const override { return size_; }
    [[nodiscard]] std::uint64_t bytes_in() const override { return bytes_in_; }

    // Errors stick: a block cut short by a failed write would make every later one
    // unreadable.
    Status end_block() override {
        if (failed_) return *failed_;
        if (block_.empty()) return ok_status();
        Status s = compressor_->compress(block_, packed_);
        if (s) s = write_all(fd_, packed_, path());
        if (!s) {
            failed_ = Error{s.error().message, path()};
            return *failed_;
        }
        size_ += packed_.size();
        block_.clear();
        return ok_status();
    }

    int fd_;
    std::unique_ptr<BlockCompressor> compressor_;
    Nanos interval_;
    std::size_t block_bytes_;
    std::string block_;   // the block being filled, as written
    std::string packed_;  // the last block compressed
    Nanos block_start_ = 0;
    std::uint64_t size_ = 0;
    std::uint64_t bytes_in_ = 0;
    std::optional<Error> failed_;
};

Result<std::unique_ptr<BlockCompressor>> make_compressor(Compression compression) {
    if (compression == Compression::zstd) {
        auto zstd = std::make_unique<ZstdCompressor>();
        if (zstd->ready()) return std::unique_ptr<BlockCompressor>(std::move(zstd));
    } else {
        auto gzip = std::make_unique<GzipCompressor>();
        if (gzip->ready()) return std::unique_ptr<BlockCompressor>(std::move(gzip));
    }
    return Error{"cannot compress: out of memory"};
}

}  // namespace

Compression compression_for(std::string_view path) {
    if (ends_with(path, ".gz")) return Compression::gzip;
    if (ends_with(path, ".zst")) return Compression::zstd;
    return Compression::none;
}

Result<std::unique_ptr<OutputFile>> create_output_file(const std::string& path,
                                                       const OutputFileOptions& options) {
    std::unique_ptr<BlockCompressor> compressor;
    if (options.compression != Compression::none) {
        Result<std::unique_ptr<BlockCompressor>> made = make_compressor(options.compression);
        if (!made) return Error{made.error().message, path};
        compressor = std::move(*made);
    }
    const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd < 0) return Error{fmt::format("cannot create the file: {}", std::strerror(errno)), path};
    if (!compressor) return std::unique_ptr<OutputFile>(new PlainFile(path, fd));
    return std::unique_ptr<OutputFile>(new BlockFile(path, fd, std::move(compressor), options));
}

}  // namespace rtuscope
