// pcap and pcapng input: packets from libpcap, or from rtuscope's own pcapng reader
// where libpcap refuses a pcapng file (pcapng_reader.hpp); the packets become chunks in
// pcap_packets.cpp. libpcap reads from a FILE*; a cookie stream puts the bytes that format
// detection already took from a pipe back in front of the rest.
#include <fcntl.h>
#include <fmt/format.h>
#include <pcap/pcap.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>
#include <memory>
#include <optional>
#include <span>
#include <string_view>
#include <utility>

#include "input/pcap.hpp"
#include "input/pcap_packets.hpp"
#include "input/pcapng_reader.hpp"
#include "input/readers.hpp"
#include "input/sources.hpp"
#include "util/io_block.hpp"

namespace rtuscope {

using pcap::Packet;
using pcap::PacketChunker;
using pcap::PacketReader;
using pcap::PcapngReader;

namespace {

// A pipe's bytes that libpcap read before its first packet are kept, up to this bound,
// so that the file can be read again from its start if libpcap refuses it.
constexpr std::size_t kMaxKeptForRereading = std::size_t{1} << 20;

bool starts_like_pcapng(std::string_view head) {
    // A section header block's type.
    return head.size() >= 4 && head.substr(0, 4) == std::string_view("\x0A\x0D\x0D\x0A", 4);
}

// The bytes format detection took from a pipe, then the rest of the pipe. Shared by the
// stream libpcap reads and the one that reads the file again: the pipe is read once.
struct Chain {
    std::string head;
    std::size_t pos = 0;
    std::FILE* rest = nullptr;
    bool close_rest = false;
    // While libpcap has not read its first packet: the bytes read from `rest`, to be read
    // again. Given up past kMaxKeptForRereading.
    bool keeping = true;
    std::string kept;
    Chain(std::string head_, std::FILE* rest_, bool close_rest_)
        : head(std::move(head_)), rest(rest_), close_rest(close_rest_) {}
    ~Chain() {
        if (close_rest && rest != nullptr) std::fclose(rest);
    }
    Chain(const Chain&) = delete;
    Chain& operator=(const Chain&) = delete;
};

ssize_t chain_read(void* cookie, char* buf, std::size_t size) {
    Chain& c = **static_cast<std::shared_ptr<Chain>*>(cookie);
    if (c.pos < c.head.size()) {
        const std::size_t n = std::min(size, c.head.size() - c.pos);
        // Binary bytes, not a C string: no terminator belongs here.
        // NOLINTNEXTLINE(bugprone-not-null-terminated-result)
        std::memcpy(buf, c.head.data() + c.pos, n);
        c.pos += n;
        return static_cast<ssize_t>(n);
    }
    if (c.rest == nullptr) return 0;
    const std::size_t n = std::fread(buf, 1, size, c.rest);
    if (n == 0 && std::ferror(c.rest) != 0) return -1;
    if (c.keeping) {
        if (c.kept.size() + n <= kMaxKeptForRereading) {
            c.kept.append(buf, n);
        } else {
            c.keeping = false;
            c.kept = std::string();
        }
    }
    return static_cast<ssize_t>(n);
}

int chain_close(void* cookie) {
    delete static_cast<std::shared_ptr<Chain>*>(cookie);
    return 0;
}

Result<std::FILE*> open_chain(std::shared_ptr<Chain> chain, const std::string& name) {
    auto* cookie = new std::shared_ptr<Chain>(std::move(chain));
    const cookie_io_functions_t io{chain_read, nullptr, nullptr, chain_close};
    std::FILE* stream = fopencookie(cookie, "rb", io);
    if (stream == nullptr) {
        const int err = errno;
        delete cookie;
        return Error{fmt::format("cannot read: {}", std::strerror(err)), name};
    }
    return stream;
}

// How a pcapng file is read again from its start, when libpcap refuses it: a file by a
// descriptor of its own, a pipe through the bytes kept of it. Whether it is pcapng is
// asked of its first bytes then (a pipe's head may be too short to tell).
class Rereading {
  public:
    explicit Rereading(int fd) : fd_(fd) {}
    explicit Rereading(std::shared_ptr<Chain> chain) : chain_(std::move(chain)) {}
    ~Rereading() {
        if (fd_ >= 0) ::close(fd_);
    }
    Rereading(const Rereading&) = delete;
    Rereading& operator=(const Rereading&) = delete;

    // libpcap has read its first packet: a pipe's bytes are no longer kept (a file's
    // can always be read again).
    void first_packet_read() {
        if (chain_ && chain_->keeping) {
            chain_->keeping = false;
            chain_->kept = std::string();
        }
    }
    // The pcapng file from its start, or null when it is no pcapng or that is no longer
    // possible. Once only.
    std::FILE* reopen() {
        if (fd_ >= 0) {
            std::array<char, 4> magic{};
            if (::pread(fd_, magic.data(), magic.size(), 0) != 4 ||
                !starts_like_pcapng(std::string_view(magic.data(), magic.size())) ||
                ::lseek(fd_, 0, SEEK_SET) != 0) {
                return nullptr;
            }
            std::FILE* file = ::fdopen(fd_, "rb");
            if (file != nullptr) fd_ = -1;
            return file;
        }
        // A stream in memory (no rest) can always be read again.
        if (!chain_ || (chain_->rest != nullptr && !chain_->keeping)) return nullptr;
        if (!starts_like_pcapng(chain_->head + chain_->kept)) return nullptr;
        // Everything read so far is the head and the bytes kept; the pipe goes on after.
        auto again = std::make_shared<Chain>(chain_->head + chain_->kept, chain_->rest,
                                             chain_->close_rest);
        again->keeping = false;
        chain_->close_rest = false;
        chain_->keeping = false;
        chain_.reset();
        Result<std::FILE*> stream = open_chain(std::move(again), {});
        return stream ? *stream : nullptr;
    }

  private:
    int fd_ = -1;
    std::shared_ptr<Chain> chain_;
};

// Packets from libpcap.
class LibpcapReader final : public PacketReader {
  public:
    // `read_buffer` is the stream's stdio buffer: kept until pcap_close has closed it.
    LibpcapReader(pcap_t* pcap, std::unique_ptr<char[]> read_buffer)
        : pcap_(pcap), read_buffer_(std::move(read_buffer)), link_type_(pcap_datalink(pcap)) {}
    ~LibpcapReader() override { pcap_close(pcap_); }
    LibpcapReader(const LibpcapReader&) = delete;
    LibpcapReader& operator=(const LibpcapReader&) = delete;

    Result<bool> next(Packet& out) override {
        pcap_pkthdr* header = nullptr;
        const u_char* data = nullptr;
        const int rc = pcap_next_ex(pcap_, &header, &data);
        if (rc == PCAP_ERROR_BREAK) return false;  // end of file
        if (rc != 1) {
            const std::string why = pcap_geterr(pcap_);
            // A file cut off in its last packet (a capture killed or still being written)
            // reads as far as it goes, as tshark reads it; a broken one stops here.
            if (why.starts_with("truncated")) {
                cut_off_ = true;
                return false;
            }
            return Error{fmt::format("packet {}: {}", packets_ + 1, why)};
        }
        ++packets_;
        // The file was opened with nanosecond precision: tv_usec holds nanoseconds.
        // pcapng timestamps are 64 bits in a unit the file chooses: the seconds libpcap
        // derives need not fit in 64-bit nanoseconds, so the conversion checks for
        // overflow. A time beyond kMaxTime is an error, as in a capture v1 text.
        Nanos time = 0;
        if (__builtin_mul_overflow(static_cast<Nanos>(header->ts.tv_sec), kNanosPerSecond,
                                   &time) ||
            __builtin_add_overflow(time, static_cast<Nanos>(header->ts.tv_usec), &time) ||
            time > kMaxTime || time < -kMaxTime) {
            return Error{fmt::format("packet {}: timestamp {} s out of range", packets_,
                                     static_cast<std::int64_t>(header->ts.tv_sec))};
        }
        out.link_type = link_type_;
        out.time = time;
        out.data = std::span<const std::uint8_t>(data, header->caplen);
        out.length = std::max(header->len, header->caplen);
        return true;
    }
    [[nodiscard]] bool cut_off() const override { return cut_off_; }

  private:
    pcap_t* pcap_;
    std::unique_ptr<char[]> read_buffer_;
    int link_type_;
    std::uint64_t packets_ = 0;
    bool cut_off_ = false;
};

std::string link_types_refused(const std::vector<int>& link_types) {
    std::string list;
    for (const int link_type : link_types) {
        list += fmt::format("{}{}", list.empty() ? "" : ", ", link_type);
    }
    return fmt::format("{} {} {} not one rtuscope reads (252, 250, 147-162, Ethernet/IP with "
                       "Modbus RTU over TCP/UDP)",
                       link_types.size() == 1 ? "link type" : "link types", list,
                       link_types.size() == 1 ? "is" : "are");
}

// rtuscope's own reader over `file`, up to its first packet; an Error when the file is no
// pcapng it can read or none of the interfaces described before the first packet
// carries RTU.
Result<std::unique_ptr<PcapngReader>> open_own_reader(std::FILE* file) {
    auto reader = std::make_unique<PcapngReader>(file);
    if (Status opened = reader->open(); !opened) return opened.error();
    const std::vector<int> link_types = reader->link_types();
    if (!link_types.empty() &&
        std::none_of(link_types.begin(), link_types.end(), pcap::supported_link_type)) {
        return Error{link_types_refused(link_types)};
    }
    return reader;
}

class PcapSource final : public ChunkSource {
  public:
    PcapSource(std::unique_ptr<PacketReader> reader, std::unique_ptr<Rereading> rereading,
               std::string name, const PcapOptions& options)
        : reader_(std::move(reader)), rereading_(std::move(rereading)), chunker_(options) {
        info_.name = std::move(name);
        info_.format = "pcap";
        info_.timed = true;
        info_.chunk_time_is_start = true;  // rtuscope and Wireshark stamp frame starts
        // Unix time, unless the numbers are too small for it: a pcap written from a
        // capture with relative times. The first chunk tells.
        first_ = read_chunk(pending_);
        if (first_ && *first_) info_.time_base = time_base_of(pending_.time);
        // A pcapng file rtuscope wrote says the line in its interfaces' descriptions.
        if (reader_) info_.line = reader_->described_line();
    }

    [[nodiscard]] const SourceInfo& info() const override { return info_; }

    Result<bool> next(Chunk& out) override {
        if (first_) {
            Result<bool> first = std::move(*first_);
            first_.reset();
            if (first && *first) std::swap(out, pending_);
            return first;
        }
        return read_chunk(out);
    }

    [[nodiscard]] std::vector<std::string> remarks() const override {
        return chunker_.remarks(reader_ && reader_->cut_off());
    }

  private:
    // The next chunk; false at the end of the file.
    Result<bool> read_chunk(Chunk& out) {
        for (;;) {
            if (chunker_.pop(out)) return true;
            if (ended_ || !reader_) return false;
            Result<bool> got = reader_->next(packet_);
            if (!got) {
                if (read_on_with_own_reader()) continue;
                ended_ = true;
                return Error{got.error().message, info_.name};
            }
            if (!*got) {
                chunker_.finish();
                ended_ = true;
                continue;
            }
            ++packets_;
            if (rereading_) rereading_->first_packet_read();
            Status added = chunker_.add(packet_, packets_);
            if (!added) return Error{added.error().message, info_.name};
        }
    }

    // libpcap refused the rest of a pcapng file (an interface of another link type or
    // snap length): the file again from its start through rtuscope's own reader, past
    // the packets libpcap gave.
    bool read_on_with_own_reader() {
        if (!rereading_) return false;
        // libpcap's stream goes first: closing it may move the file's offset, which a
        // duplicate descriptor shares.
        reader_.reset();
        std::FILE* again = rereading_->reopen();
        rereading_.reset();
        if (again == nullptr) return false;
        auto reader = std::make_unique<PcapngReader>(again);
        for (std::uint64_t i = 0; i < packets_; ++i) {
            Result<bool> got = reader->next(packet_);
            if (!got || !*got) return false;
        }
        reader_ = std::move(reader);
        return true;
    }

    std::unique_ptr<PacketReader> reader_;
    // Set while libpcap reads a file it may yet refuse (a pcapng file with an interface of
    // another link type further on).
    std::unique_ptr<Rereading> rereading_;
    PacketChunker chunker_;
    Packet packet_;
    std::uint64_t packets_ = 0;
    bool ended_ = false;
    SourceInfo info_;
    // The first chunk, read ahead for the time base, and what reading it gave.
    Chunk pending_;
    std::optional<Result<bool>> first_;
};

}  // namespace

bool looks_like_pcap(std::string_view head) {
    if (head.size() < 4) return false;
    const auto b = [&](std::size_t i) { return static_cast<std::uint8_t>(head[i]); };
    const std::uint32_t le = b(0) | (b(1) << 8) | (b(2) << 16) | (std::uint32_t{b(3)} << 24);
    const std::uint32_t be = b(3) | (b(2) << 8) | (b(1) << 16) | (std::uint32_t{b(0)} << 24);
    // Classic pcap (micro- and nanosecond, and the "modified" Kuznetzov variant), either
    // byte order; the major version 2 that follows makes a raw dump that happens to
    // start with the magic very unlikely to be taken for one.
    for (const std::uint32_t magic : {0xA1B2C3D4U, 0xA1B23C4DU, 0xA1B2CD34U}) {
        if (head.size() >= 6 && le == magic && b(4) == 2 && b(5) == 0) return true;
        if (head.size() >= 6 && be == magic && b(4) == 0 && b(5) == 2) return true;
    }
    // pcapng: a section header block, then its byte-order magic.
    if (be == 0x0A0D0D0AU && head.size() >= 12) {
        const std::string_view bom = head.substr(8, 4);
        return bom == std::string_view("\x1A\x2B\x3C\x4D", 4) ||
               bom == std::string_view("\x4D\x3C\x2B\x1A", 4);
    }
    return false;
}

namespace {

// Reads from `rest` into `head` what it lacks of a pcapng file's section header block
// (its first block), and no more: a pipe may be a capture still being written.
void read_section_header(std::string& head, std::FILE* rest) {
    constexpr std::size_t kStart = 12;  // type, length, byte-order magic
    constexpr std::size_t kLongest = std::size_t{64} << 10;
    const auto read_up_to = [&](std::size_t size) {
        if (rest == nullptr || head.size() >= size) return;
        const std::size_t had = head.size();
        head.resize(size);
        head.resize(had + std::fread(head.data() + had, 1, size - had, rest));
    };
    if (head.size() < 4 && rest != nullptr) read_up_to(4);
    if (!starts_like_pcapng(head)) return;
    read_up_to(kStart);
    if (head.size() < kStart) return;
    const auto byte = [&](std::size_t i) { return static_cast<std::uint8_t>(head[i]); };
    const bool big = head.substr(8, 4) == std::string_view("\x1A\x2B\x3C\x4D", 4);
    const std::uint32_t length =
        big ? (std::uint32_t{byte(4)} << 24) | (byte(5) << 16) | (byte(6) << 8) | byte(7)
            : (std::uint32_t{byte(7)} << 24) | (byte(6) << 16) | (byte(5) << 8) | byte(4);
    if (length <= kLongest) read_up_to(length);
}

}  // namespace

Result<std::unique_ptr<ChunkSource>> pcap_source_from_stream(std::string head, std::FILE* rest,
                                                             bool close_rest, std::string name,
                                                             const PcapOptions& options) {
    read_section_header(head, rest);
    const bool ours = pcap::written_by_rtuscope(head);
    std::unique_ptr<Rereading> rereading;
    // A file of ours whose head was read from its own start (it stands just past the head)
    // and that can go back there is libpcap's to read as it is: through the chain below,
    // every packet's reads would take glibc's slow generic path.
    std::FILE* stream = nullptr;
    // A descriptor of its own reads it again if libpcap refuses it.
    const long position = rest != nullptr ? std::ftell(rest) : -1;
    const int fd = close_rest && position >= 0 &&
                           static_cast<std::size_t>(position) == head.size() &&
                           ::fileno(rest) >= 0
                       ? ::fcntl(::fileno(rest), F_DUPFD_CLOEXEC, 0)
                       : -1;
    if (fd >= 0 && std::fseek(rest, 0, SEEK_SET) == 0) {
        stream = rest;
        rereading = std::make_unique<Rereading>(fd);
    } else {
        if (fd >= 0) ::close(fd);
        auto chain = std::make_shared<Chain>(std::move(head), rest, close_rest);
        Result<std::FILE*> opened = open_chain(chain, name);
        if (!opened) return opened.error();
        stream = *opened;
        rereading = std::make_unique<Rereading>(std::move(chain));
    }
    // A pcapng file rtuscope wrote: its own reader, for the direction flags, comments and
    // line settings libpcap does not give.
    if (ours) {
        rereading.reset();
        Result<std::unique_ptr<PcapngReader>> own = open_own_reader(stream);
        if (!own) return Error{own.error().message, name};
        return std::unique_ptr<ChunkSource>(
            std::make_unique<PcapSource>(std::move(*own), nullptr, std::move(name), options));
    }
    // libpcap reads each packet with two small freads: with stdio's own 4 KiB buffer, a
    // read() every ~60 packets of ours. Set before libpcap's first read; the file taken
    // as it is has been seeked back to its start, its buffer empty.
    auto read_buffer = give_stdio_buffer(stream);
    char errbuf[PCAP_ERRBUF_SIZE] = {};
    pcap_t* pcap =
        pcap_fopen_offline_with_tstamp_precision(stream, PCAP_TSTAMP_PRECISION_NANO, errbuf);
    const std::string refused =
        pcap == nullptr
            ? fmt::format("not a pcap or pcapng file rtuscope can read: {}", errbuf)
            : (pcap::supported_link_type(pcap_datalink(pcap))
                   ? std::string()
                   : link_types_refused({pcap_datalink(pcap)}));
    if (refused.empty()) {
        return std::unique_ptr<ChunkSource>(std::make_unique<PcapSource>(
            std::make_unique<LibpcapReader>(pcap, std::move(read_buffer)), std::move(rereading),
            std::move(name), options));
    }
    // libpcap refuses the file, or reads only an interface that carries no RTU: a pcapng
    // file may hold others.
    const bool opened = pcap != nullptr;
    if (opened) {
        pcap_close(pcap);
    } else {
        std::fclose(stream);  // not taken over on failure
    }
    std::FILE* again = rereading ? rereading->reopen() : nullptr;
    if (again == nullptr) return Error{refused, name};
    Result<std::unique_ptr<PcapngReader>> own = open_own_reader(again);
    if (!own) {
        // The link types the own reader found are what the user needs to know; any other
        // complaint of a file libpcap refused too is libpcap's.
        return Error{opened ? own.error().message : refused, name};
    }
    return std::unique_ptr<ChunkSource>(
        std::make_unique<PcapSource>(std::move(*own), nullptr, std::move(name), options));
}

Result<std::unique_ptr<ChunkSource>> pcap_source_from_memory(std::string content, std::string name,
                                                             const PcapOptions& options) {
    return pcap_source_from_stream(std::move(content), nullptr, false, std::move(name), options);
}

Result<std::unique_ptr<ChunkSource>> pcapng_source_from_memory(std::string content,
                                                               std::string name) {
    auto chain = std::make_shared<Chain>(std::move(content), nullptr, false);
    chain->keeping = false;
    Result<std::FILE*> stream = open_chain(std::move(chain), name);
    if (!stream) return stream.error();
    Result<std::unique_ptr<PcapngReader>> own = open_own_reader(*stream);
    if (!own) return Error{own.error().message, name};
    return std::unique_ptr<ChunkSource>(
        std::make_unique<PcapSource>(std::move(*own), nullptr, std::move(name), PcapOptions{}));
}

Result<std::unique_ptr<ChunkSource>> open_pcap_source(const std::string& path,
                                                      const PcapOptions& options) {
    return open_source(path, InputFormat::pcap, options);
}

}  // namespace rtuscope
