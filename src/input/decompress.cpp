// Compressed input: a glibc cookie stream that reads the compressed bytes and hands out
// the decompressed ones, a piece of the caller's size at a time. Memory stays bounded
// whatever the ratio (a decompression bomb only takes time, as a file of its decompressed
// size would): zlib's window is 32 KiB, and zstd frames that ask for more than 128 MiB of
// window (zstd's own default limit, what `zstd` without --long=28 or more writes) are
// refused; the readers bound their lines.
#include "input/decompress.hpp"

#include <fmt/format.h>
#include <zlib.h>
#include <zstd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <span>
#include <utility>

#include "util/io_block.hpp"

namespace rtuscope {
namespace {

constexpr int kMostZstdWindowLog = 27;
// The decompressed bytes of a block held until it ends: four of rtuscope's blocks.
constexpr std::size_t kMostHeldBack = std::size_t{4} << 20;

// One step of a decoder: what it took and gave, and where the member or frame stands.
struct Step {
    std::size_t consumed = 0;
    std::size_t produced = 0;
    bool in_block = false;  // inside a member or frame after the step
    bool ended = false;     // a member or frame ended in the step
};

class Decoder {
  public:
    Decoder() = default;
    virtual ~Decoder() = default;
    Decoder(const Decoder&) = delete;
    Decoder& operator=(const Decoder&) = delete;
    // Decompresses from `in` into `out` (either may be empty: output still held back is
    // flushed); an Error (the library's reason) on corrupt data.
    virtual Result<Step> step(std::string_view in, std::span<char> out) = 0;
};

class ZstdDecoder final : public Decoder {
  public:
    ZstdDecoder() : dctx_(ZSTD_createDCtx()) {
        if (dctx_ != nullptr)
            ZSTD_DCtx_setParameter(dctx_, ZSTD_d_windowLogMax, kMostZstdWindowLog);
    }
    ~ZstdDecoder() override { ZSTD_freeDCtx(dctx_); }
    ZstdDecoder(const ZstdDecoder&) = delete;
    ZstdDecoder& operator=(const ZstdDecoder&) = delete;
    [[nodiscard]] bool ready() const { return dctx_ != nullptr; }

    Result<Step> step(std::string_view in, std::span<char> out) override {
        ZSTD_inBuffer input{in.data(), in.size(), 0};
        ZSTD_outBuffer output{out.data(), out.size(), 0};
        const std::size_t rc = ZSTD_decompressStream(dctx_, &output, &input);
        if (ZSTD_isError(rc) != 0) return Error{ZSTD_getErrorName(rc)};
        Step s;
        s.consumed = input.pos;
        s.produced = output.pos;
        // 0: a frame is decoded and flushed, and the next byte starts another.
        s.in_block = rc != 0;
        s.ended = rc == 0 && (s.consumed != 0 || s.produced != 0);
        return s;
    }

  private:
    ZSTD_DCtx* dctx_;
};

class GzipDecoder final : public Decoder {
  public:
    GzipDecoder() {
        // 15 + 16: gzip only, any window up to 32 KiB.
        ready_ = inflateInit2(&z_, 15 + 16) == Z_OK;
    }
    ~GzipDecoder() override {
        if (ready_) inflateEnd(&z_);
    }
    GzipDecoder(const GzipDecoder&) = delete;
    GzipDecoder& operator=(const GzipDecoder&) = delete;
    [[nodiscard]] bool ready() const { return ready_; }

    Result<Step> step(std::string_view in, std::span<char> out) override {
        // zlib's interface is not const-correct; it does not write its input.
        z_.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(in.data()));
        z_.avail_in = static_cast<uInt>(std::min<std::size_t>(in.size(), 1U << 30));
        z_.next_out = reinterpret_cast<Bytef*>(out.data());
        z_.avail_out = static_cast<uInt>(std::min<std::size_t>(out.size(), 1U << 30));
        const uInt avail_in = z_.avail_in;
        const uInt avail_out = z_.avail_out;
        const int rc = inflate(&z_, Z_NO_FLUSH);
        Step s;
        s.consumed = avail_in - z_.avail_in;
        s.produced = avail_out - z_.avail_out;
        if (rc == Z_STREAM_END) {
            // The next member, if any, starts with the next byte.
            if (inflateReset(&z_) != Z_OK) return Error{"zlib refuses to reset"};
            in_member_ = false;
            s.ended = true;
        } else if (rc == Z_OK || rc == Z_BUF_ERROR) {
            // Z_BUF_ERROR: no progress possible without more input or room.
            if (s.consumed != 0) in_member_ = true;
        } else {
            return Error{z_.msg != nullptr ? z_.msg : "not gzip data"};
        }
        s.in_block = in_member_;
        return s;
    }

  private:
    z_stream z_{};
    bool ready_ = false;
    bool in_member_ = false;
};

const char* compression_name(Compression compression) {
    return compression == Compression::zstd ? "zstd" : "gzip";
}

// What a block is called: "frame", "member".
const char* block_word(Compression compression) {
    return compression == Compression::zstd ? "frame" : "member";
}

// The cookie: the compressed bytes (the head, then `rest` read in blocks) and the decoder.
class Inflow {
  public:
    Inflow(std::unique_ptr<Decoder> decoder, std::shared_ptr<Decompression> state, std::string head,
           std::FILE* rest, bool close_rest)
        : decoder_(std::move(decoder)),
          state_(std::move(state)),
          buf_(std::move(head)),
          rest_(rest),
          close_rest_(close_rest) {}
    ~Inflow() {
        if (close_rest_ && rest_ != nullptr) std::fclose(rest_);
    }
    Inflow(const Inflow&) = delete;
    Inflow& operator=(const Inflow&) = delete;

    ssize_t read(char* out, std::size_t size) {
        for (;;) {
            if (ready_ > released_) {
                const std::size_t n = std::min(size, ready_ - released_);
                std::memcpy(out, held_.data() + released_, n);
                released_ += n;
                if (released_ == filled_) released_ = ready_ = filled_ = 0;
                return static_cast<ssize_t>(n);
            }
            if (!state_->error.empty()) return fail(EIO);
            if (pos_ == buf_.size() && !flushing_) {
                if (input_ended_) {
                    // What is held of a block cut off is dropped: unchecked, and it may
                    // end inside a line.
                    state_->cut_off = in_block_;
                    return 0;
                }
                if (const int err = refill(); err != 0) return fail(err);
                continue;
            }
            if (released_ != 0) {
                // Room at the front for what decodes next.
                held_.erase(0, released_);
                filled_ -= released_;
                ready_ -= released_;
                released_ = 0;
            }
            if (held_.size() - filled_ < kIoBlockBytes) held_.resize(filled_ + kIoBlockBytes);
            const std::string_view in = std::string_view(buf_).substr(pos_);
            const std::span<char> room(held_.data() + filled_, held_.size() - filled_);
            Result<Step> step = decoder_->step(in, room);
            if (!step) {
                corrupt(step.error().message);
                continue;  // what is ready goes first
            }
            pos_ += step->consumed;
            offset_ += step->consumed;
            filled_ += step->produced;
            in_block_ = step->in_block;
            if (step->ended) ++state_->blocks;
            // A block is handed out once it has ended (its checksum checked), or once
            // kMostHeldBack of it are held: a file compressed whole is one block, and
            // is handed out unchecked as it comes, as zcat does.
            if (!in_block_ || filled_ >= kMostHeldBack) ready_ = filled_;
            // Output may be held back by the decoder still when the room ran out.
            flushing_ = step->produced == room.size();
            if (step->consumed == 0 && step->produced == 0 && !in.empty()) {
                // A decoder that neither takes nor gives would spin forever.
                corrupt("the decoder makes no progress");
            }
        }
    }

  private:
    ssize_t fail(int err) {
        errno = err;
        return -1;
    }

    void corrupt(const std::string& why) {
        state_->error = fmt::format(
            "corrupt {} data near byte {} of the file ({} complete {}s "
            "before it): {}",
            compression_name(state_->compression), offset_, state_->blocks,
            block_word(state_->compression), why);
        // What is held of the block is not handed out: it failed its check.
        filled_ = ready_;
    }

    // Reads the next block of `rest`; 0, or the errno of a failed read.
    int refill() {
        buf_.resize(kIoBlockBytes);
        pos_ = 0;
        const std::size_t n = rest_ != nullptr ? std::fread(buf_.data(), 1, buf_.size(), rest_) : 0;
        buf_.resize(n);
        if (n == 0) {
            if (rest_ != nullptr && std::ferror(rest_) != 0) {
                const int err = errno;
                // A read interrupted by a stop signal can be tried again.
                std::clearerr(rest_);
                return err != 0 ? err : EIO;
            }
            input_ended_ = true;
        }
        return 0;
    }

    std::unique_ptr<Decoder> decoder_;
    std::shared_ptr<Decompression> state_;
    std::string buf_;  // compressed bytes
    std::size_t pos_ = 0;
    std::FILE* rest_;
    bool close_rest_;
    bool input_ended_ = false;
    bool in_block_ = false;
    bool flushing_ = false;
    std::uint64_t offset_ = 0;  // compressed bytes consumed
    // Decompressed bytes: [released_, ready_) are to be handed out, [ready_, filled_)
    // are of a block not yet ended.
    std::string held_;
    std::size_t released_ = 0;
    std::size_t ready_ = 0;
    std::size_t filled_ = 0;
};

ssize_t inflow_read(void* cookie, char* buf, std::size_t size) {
    return static_cast<Inflow*>(cookie)->read(buf, size);
}

int inflow_close(void* cookie) {
    delete static_cast<Inflow*>(cookie);
    return 0;
}

class DecompressedSource final : public ChunkSource {
  public:
    DecompressedSource(std::unique_ptr<ChunkSource> inner,
                       std::shared_ptr<const Decompression> state)
        : inner_(std::move(inner)), state_(std::move(state)) {}

    [[nodiscard]] const SourceInfo& info() const override { return inner_->info(); }

    Result<bool> next(Chunk& out) override {
        Result<bool> got = inner_->next(out);
        // The reader says only that it could not read; the stream knows why.
        if (!got && !state_->error.empty()) return Error{state_->error, inner_->info().name};
        return got;
    }

    [[nodiscard]] std::vector<std::string> remarks() const override {
        std::vector<std::string> out;
        if (state_->cut_off) {
            out.push_back(fmt::format(
                "the file ends inside a {} (cut off before it was complete: a run killed or "
                "still being written); the {} complete {}s before it are read",
                block_name(state_->compression), state_->blocks, block_word(state_->compression)));
        }
        for (std::string& remark : inner_->remarks()) out.push_back(std::move(remark));
        return out;
    }

    [[nodiscard]] bool ended_by_stop() const override { return inner_->ended_by_stop(); }

  private:
    std::unique_ptr<ChunkSource> inner_;
    std::shared_ptr<const Decompression> state_;
};

}  // namespace

const char* block_name(Compression compression) {
    return compression == Compression::zstd ? "zstd frame" : "gzip member";
}

Compression compression_of(std::string_view head) {
    if (head.starts_with(std::string_view("\x28\xB5\x2F\xFD", 4))) return Compression::zstd;
    // ID1 ID2, then CM 8 (deflate, the only method gzip defines) and FLG with its reserved
    // bits clear: a raw dump that starts with 1F 8B is taken for gzip only if it goes on so.
    if (head.size() >= 4 && head.starts_with("\x1F\x8B\x08") &&
        (static_cast<unsigned char>(head[3]) & 0xE0) == 0) {
        return Compression::gzip;
    }
    return Compression::none;
}

Result<DecompressingStream> open_decompressing(Compression compression, std::string head,
                                               std::FILE* rest, bool close_rest,
                                               const std::string& name) {
    std::unique_ptr<Decoder> decoder;
    if (compression == Compression::zstd) {
        auto zstd = std::make_unique<ZstdDecoder>();
        if (zstd->ready()) decoder = std::move(zstd);
    } else if (compression == Compression::gzip) {
        auto gzip = std::make_unique<GzipDecoder>();
        if (gzip->ready()) decoder = std::move(gzip);
    }
    if (!decoder) {
        if (close_rest && rest != nullptr) std::fclose(rest);
        return Error{"cannot decompress: out of memory", name};
    }
    auto state = std::make_shared<Decompression>();
    state->compression = compression;
    auto* inflow = new Inflow(std::move(decoder), state, std::move(head), rest, close_rest);
    const cookie_io_functions_t io{inflow_read, nullptr, nullptr, inflow_close};
    std::FILE* stream = fopencookie(inflow, "rb", io);
    if (stream == nullptr) {
        const int err = errno;
        delete inflow;
        return Error{fmt::format("cannot read: {}", std::strerror(err)), name};
    }
    return DecompressingStream{stream, std::move(state)};
}

std::unique_ptr<ChunkSource> with_decompression(std::unique_ptr<ChunkSource> source,
                                                std::shared_ptr<const Decompression> state) {
    return std::make_unique<DecompressedSource>(std::move(source), std::move(state));
}

}  // namespace rtuscope
