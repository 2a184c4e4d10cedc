// Stage 1, sources: opening inputs, guessing their format, and the buffered input the
// readers share. The readers themselves live in capture_reader.cpp, raw_reader.cpp,
// hex_reader.cpp and pcap_reader.cpp.
#include "input/sources.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "input/decompress.hpp"
#include "input/pcap.hpp"
#include "input/readers.hpp"
#include "util/io_block.hpp"

namespace rtuscope {
namespace detail {

InputBuffer::InputBuffer(std::string initial, std::FILE* file, bool close_file, std::string name)
    : buf_(std::move(initial)),
      end_(buf_.size()),
      file_(file),
      close_file_(close_file),
      eof_(file == nullptr),
      name_(std::move(name)) {}

InputBuffer::~InputBuffer() {
    if (close_file_ && file_ != nullptr) std::fclose(file_);
}

Result<bool> InputBuffer::fill() {
    if (eof_) return false;
    if (pos_ > 0) {
        std::memmove(buf_.data(), buf_.data() + pos_, end_ - pos_);
        end_ -= pos_;
        scan_ -= pos_;
        pos_ = 0;
    }
    // The sniffed head is only 4 KiB; reading on in pieces that small would be slow.
    if (buf_.size() < kIoBlockBytes) {
        buf_.resize(kIoBlockBytes);
    } else if (end_ == buf_.size()) {
        buf_.resize(buf_.size() * 2);
    }
    const std::size_t n = std::fread(buf_.data() + end_, 1, buf_.size() - end_, file_);
    end_ += n;
    if (n == 0) {
        if (std::ferror(file_) != 0) {
            // A read interrupted by a stop signal is the end of this run's input; the
            // pipeline sees the stop and says so.
            if (errno == EINTR) {
                std::clearerr(file_);
                eof_ = true;
                return false;
            }
            return Error{fmt::format("cannot read: {}", std::strerror(errno)), name_};
        }
        eof_ = true;
        return false;
    }
    return true;
}

Result<bool> InputBuffer::next_line(std::string_view& line) {
    for (;;) {
        const void* found =
            scan_ < end_ ? std::memchr(buf_.data() + scan_, '\n', end_ - scan_) : nullptr;
        std::size_t stop = end_;
        if (found != nullptr) {
            stop = static_cast<std::size_t>(static_cast<const char*>(found) - buf_.data());
        } else {
            scan_ = end_;
        }
        if (stop - pos_ > kMaxLineBytes) {
            return Error{
                fmt::format("line longer than {} bytes; is this a text file?", kMaxLineBytes),
                name_, line_ + 1};
        }
        if (found == nullptr) {
            Result<bool> more = fill();
            if (!more) return more.error();
            if (*more) continue;
            if (pos_ == end_) return false;  // the input ended with '\n' or was empty
            stop = end_;                     // fill() may have moved the bytes
        }
        line = std::string_view(buf_.data() + pos_, stop - pos_);
        pos_ = scan_ = found != nullptr ? stop + 1 : stop;
        if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
        ++line_;
        return true;
    }
}

Result<bool> InputBuffer::next_block(std::size_t max, std::string_view& block) {
    if (pos_ == end_) {
        Result<bool> more = fill();
        if (!more) return more.error();
        if (!*more) return false;
    }
    const std::size_t n = std::min(max, end_ - pos_);
    block = std::string_view(buf_.data() + pos_, n);
    pos_ += n;
    scan_ = std::max(scan_, pos_);
    return true;
}

std::string quote_token(std::string_view token) {
    constexpr std::size_t kShown = 40;
    std::string out = "\"";
    for (std::size_t i = 0; i < token.size() && i < kShown; ++i) {
        const auto c = static_cast<unsigned char>(token[i]);
        if (c < 0x20 || c >= 0x7F || c == '"' || c == '\\') {
            out += fmt::format("\\x{:02X}", c);
        } else {
            out += static_cast<char>(c);
        }
    }
    if (token.size() > kShown) out += "...";
    out += '"';
    return out;
}

}  // namespace detail

namespace {

constexpr std::size_t kSniffBytes = 4096;
constexpr std::string_view kUtf8Bom = "\xEF\xBB\xBF";

// A sequence cut off by the end of `text` counts as valid: the sniffed head of a file
// ends wherever 4 KiB ends.
bool valid_utf8(std::string_view text) {
    std::size_t i = 0;
    const std::size_t n = text.size();
    while (i < n) {
        const auto c = static_cast<unsigned char>(text[i]);
        if (c < 0x80) {
            ++i;
            continue;
        }
        std::size_t len = 0;
        unsigned char lo = 0x80;
        unsigned char hi = 0xBF;
        if (c >= 0xC2 && c <= 0xDF) {
            len = 2;
        } else if (c >= 0xE0 && c <= 0xEF) {
            len = 3;
            if (c == 0xE0) lo = 0xA0;  // overlong
            if (c == 0xED) hi = 0x9F;  // surrogates
        } else if (c >= 0xF0 && c <= 0xF4) {
            len = 4;
            if (c == 0xF0) lo = 0x90;  // overlong
            if (c == 0xF4) hi = 0x8F;  // above U+10FFFF
        } else {
            return false;
        }
        for (std::size_t k = 1; k < len; ++k) {
            if (i + k >= n) return true;
            const auto d = static_cast<unsigned char>(text[i + k]);
            if (d < (k == 1 ? lo : 0x80) || d > (k == 1 ? hi : 0xBF)) return false;
        }
        i += len;
    }
    return true;
}

// The length of the colour escape at the start of `text` (ESC [ digits and ';' then a
// letter, as a logger that colours its lines writes, ESPHome's among them), 0 if there is
// none. One cut off by the end of the sniffed head counts.
std::size_t colour_escape_length(std::string_view text) {
    constexpr std::size_t kLongest = 16;
    if (text.size() < 2 || text[1] != '[') return text.size() == 1 ? 1 : 0;
    for (std::size_t i = 2; i < text.size() && i < kLongest; ++i) {
        const char c = text[i];
        if ((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z')) return i + 1;
        if ((c < '0' || c > '9') && c != ';') return 0;
    }
    return text.size() < kLongest ? text.size() : 0;
}

Result<std::unique_ptr<ChunkSource>> make_source(std::unique_ptr<detail::InputBuffer> in,
                                                 InputFormat format) {
    switch (format) {
        case InputFormat::capture:
            return detail::make_capture_reader(std::move(in));
        case InputFormat::hex:
            return detail::make_hex_reader(std::move(in));
        case InputFormat::raw:
        case InputFormat::automatic:
        case InputFormat::pcap:  // read through libpcap, never from an InputBuffer
            break;
    }
    return detail::make_raw_reader(std::move(in));
}

// The first bytes of `file`, for the sniffing of its compression and format;
// `read_errno`: why a read failed after them, 0 when none did.
std::string read_head(std::FILE* file, int& read_errno) {
    std::string head(kSniffBytes, '\0');
    const std::size_t n = std::fread(head.data(), 1, head.size(), file);
    read_errno = n < head.size() && std::ferror(file) != 0 ? (errno != 0 ? errno : EIO) : 0;
    head.resize(n);
    return head;
}

// The reader of `format` (guessed from `head` when automatic) over `head`, then `file`.
Result<std::unique_ptr<ChunkSource>> open_reader(std::string head, std::FILE* file, bool close_file,
                                                 const std::string& path, InputFormat format,
                                                 const PcapOptions& pcap) {
    if (format == InputFormat::automatic) {
        if (head.empty()) {
            if (close_file) std::fclose(file);
            return Error{"is empty: nothing to decode", path};
        }
        format = detect_input_format(head);
    }
    if (format == InputFormat::pcap) {
        return pcap_source_from_stream(std::move(head), file, close_file, path, pcap);
    }
    auto in = std::make_unique<detail::InputBuffer>(std::move(head), file, close_file, path);
    return make_source(std::move(in), format);
}

}  // namespace

Result<InputFormat> parse_input_format(std::string_view name) {
    if (name == "auto") return InputFormat::automatic;
    if (name == "capture") return InputFormat::capture;
    if (name == "raw") return InputFormat::raw;
    if (name == "hex") return InputFormat::hex;
    if (name == "pcap") return InputFormat::pcap;
    return Error{fmt::format("unknown input format {} (expected auto, capture, raw, hex or pcap)",
                             detail::quote_token(name))};
}

const char* to_string(InputFormat format) {
    switch (format) {
        case InputFormat::automatic:
            return "auto";
        case InputFormat::capture:
            return "capture";
        case InputFormat::raw:
            return "raw";
        case InputFormat::hex:
            return "hex";
        case InputFormat::pcap:
            return "pcap";
    }
    return "?";
}

InputFormat detect_input_format(std::string_view head) {
    if (looks_like_pcap(head)) return InputFormat::pcap;
    if (head.starts_with(kUtf8Bom)) head.remove_prefix(kUtf8Bom.size());
    if (head.starts_with("# rtuscope capture")) return InputFormat::capture;
    for (std::size_t i = 0; i < head.size(); ++i) {
        const auto c = static_cast<unsigned char>(head[i]);
        if (c == 0x1B) {
            const std::size_t n = colour_escape_length(head.substr(i));
            if (n == 0) return InputFormat::raw;
            i += n - 1;
            continue;
        }
        if ((c < 0x20 && c != '\t' && c != '\r' && c != '\n') || c == 0x7F) {
            return InputFormat::raw;
        }
    }
    // The sniffed head may end inside a multi-byte character.
    bool text = false;
    for (std::size_t cut = 0; cut < 4 && cut <= head.size() && !text; ++cut) {
        text = valid_utf8(head.substr(0, head.size() - cut));
    }
    if (!text || head.empty()) return InputFormat::raw;
    // Text (coloured or not) is a log or a manual: read as hex, which says which lines
    // held no frame.
    return InputFormat::hex;
}

Result<std::unique_ptr<ChunkSource>> open_source(const std::string& path, InputFormat format,
                                                 const PcapOptions& pcap) {
    std::FILE* file = stdin;
    const bool is_stdin = path == "-";
    if (!is_stdin) {
        const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
        if (fd < 0) return Error{fmt::format("cannot open: {}", std::strerror(errno)), path};
        struct stat st {};
        if (::fstat(fd, &st) != 0) {
            const int err = errno;
            ::close(fd);
            return Error{fmt::format("cannot open: {}", std::strerror(err)), path};
        }
        if (S_ISDIR(st.st_mode)) {
            ::close(fd);
            return Error{"is a directory", path};
        }
        if (S_ISCHR(st.st_mode) || S_ISBLK(st.st_mode)) {
            ::close(fd);
            return Error{"is a device, not a file (to listen to a serial port: rtuscope sniff)",
                         path};
        }
        // An empty capture is almost always a recording that never started; saying so
        // beats printing a summary of nothing.
        if (S_ISREG(st.st_mode) && st.st_size == 0) {
            ::close(fd);
            return Error{"is empty: nothing to decode", path};
        }
        file = ::fdopen(fd, "rb");
        if (file == nullptr) {
            const int err = errno;
            ::close(fd);
            return Error{fmt::format("cannot open: {}", std::strerror(err)), path};
        }
    }
    // Sniffed bytes are kept and handed to the reader rather than seeking back, so pipes
    // and stdin work the same as files.
    int read_errno = 0;
    std::string head = read_head(file, read_errno);
    if (read_errno != 0) {
        if (!is_stdin) std::fclose(file);
        return Error{fmt::format("cannot read: {}", std::strerror(read_errno)), path};
    }
    bool close_file = !is_stdin;
    // Compressed input is taken apart whatever its format, and its head read again.
    std::shared_ptr<const Decompression> decompression;
    if (const Compression compression = compression_of(head); compression != Compression::none) {
        Result<DecompressingStream> stream =
            open_decompressing(compression, std::move(head), file, close_file, path);
        if (!stream) return stream.error();
        file = stream->file;
        close_file = true;  // the stream, not what it reads: closing it leaves stdin open
        decompression = stream->state;
        head = read_head(file, read_errno);
        // Corrupt data after whole blocks: those are read first, the error after them.
        if (read_errno != 0 && (decompression->error.empty() || head.empty())) {
            std::fclose(file);
            return decompression->error.empty()
                       ? Error{fmt::format("cannot read: {}", std::strerror(read_errno)), path}
                       : Error{decompression->error, path};
        }
        std::clearerr(file);
        if (head.empty() && decompression->cut_off) {
            std::fclose(file);
            return Error{fmt::format("ends inside its first {} (cut off before it was complete): "
                                     "nothing to decode",
                                     block_name(decompression->compression)),
                         path};
        }
    }
    Result<std::unique_ptr<ChunkSource>> source =
        open_reader(std::move(head), file, close_file, path, format, pcap);
    if (!decompression) return source;
    if (!source) {
        if (!decompression->error.empty()) return Error{decompression->error, path};
        return source;
    }
    return with_decompression(std::move(*source), std::move(decompression));
}

Result<std::unique_ptr<ChunkSource>> source_from_memory(std::string content, std::string name,
                                                        InputFormat format,
                                                        const PcapOptions& pcap) {
    if (format == InputFormat::automatic) {
        format = detect_input_format(std::string_view(content).substr(0, kSniffBytes));
    }
    if (format == InputFormat::pcap)
        return pcap_source_from_memory(std::move(content), std::move(name), pcap);
    auto in =
        std::make_unique<detail::InputBuffer>(std::move(content), nullptr, false, std::move(name));
    return make_source(std::move(in), format);
}

}  // namespace rtuscope
