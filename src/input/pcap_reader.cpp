// pcap and pcapng input through libpcap: each packet that holds a Modbus RTU frame becomes
// one chunk. Which part of a packet is the frame depends on the link type; see
// read_packet(). libpcap reads from a FILE*; a cookie stream puts the bytes that format
// detection already took from a pipe back in front of the rest.
#include <fmt/format.h>
#include <pcap/pcap.h>

#include <cerrno>
#include <cstring>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string_view>
#include <utility>

#include "input/pcap.hpp"
#include "input/readers.hpp"
#include "input/sources.hpp"
#include "util/io_block.hpp"

namespace rtuscope {

namespace {

using Bytes = std::span<const std::uint8_t>;

// Link types as libpcap reports them (pcap_datalink gives DLT_ values; for most they are
// the LINKTYPE_ values of the file).
constexpr int kDltNull = 0;
constexpr int kDltEthernet = 1;
constexpr int kDltRaw = 12;         // DLT_RAW on most systems (LINKTYPE_RAW is 101)
constexpr int kDltRawOpenBsd = 14;  // DLT_RAW on OpenBSD
constexpr int kLinktypeRaw = 101;
constexpr int kDltLoop = 108;
constexpr int kDltLinuxSll = 113;
constexpr int kDltUser0 = 147;
constexpr int kDltUser15 = 162;
constexpr int kDltIpv4 = 228;
constexpr int kDltIpv6 = 229;
constexpr int kDltLinuxSll2 = 276;

constexpr std::uint16_t kTagEndOfOpt = 0;
constexpr std::uint16_t kTagDissectorName = 12;
constexpr std::uint16_t kTagHeuristicName = 13;
constexpr std::uint16_t kTagSrcPort = 25;
constexpr std::uint16_t kTagDstPort = 26;
// rtuscope's own (output/pcap_writer.cpp): the frame's duration, the top bit set when its
// start is an estimate.
constexpr std::uint16_t kTagFrameTiming = 0xF2A5;
constexpr std::uint64_t kTimeEstimated = std::uint64_t{1} << 63U;
constexpr std::size_t kRtacHeaderBytes = 12;  // secs, usecs, event, control lines, footer

std::uint16_t be16(Bytes b, std::size_t at) {
    return static_cast<std::uint16_t>((b[at] << 8) | b[at + 1]);
}

std::uint32_t be32(Bytes b, std::size_t at) {
    return (std::uint32_t{be16(b, at)} << 16) | be16(b, at + 2);
}

bool supported_link_type(int dlt) {
    switch (dlt) {
        case kLinktypeUpperPdu:
        case kLinktypeRtacSerial:
        case kDltNull:
        case kDltEthernet:
        case kDltRaw:
        case kDltRawOpenBsd:
        case kLinktypeRaw:
        case kDltLoop:
        case kDltLinuxSll:
        case kDltIpv4:
        case kDltIpv6:
        case kDltLinuxSll2:
            return true;
        default:
            return dlt >= kDltUser0 && dlt <= kDltUser15;
    }
}

std::string_view channel_for_ports(std::uint32_t src, std::uint32_t dst) {
    if (dst == kModbusPort && src != kModbusPort) return "master";
    if (src == kModbusPort && dst != kModbusPort) return "slave";
    return {};
}

// What one packet holds: the frame and its direction, or why there is none (counted in
// the remarks), or an Error for a packet that is broken where it should not be.
struct Extracted {
    Bytes frame;
    std::string_view channel;  // "master", "slave" or none
    std::string skipped;       // non-empty: no frame, and why
    Nanos duration = kNoTime;  // the frame's time on the line, when the packet says
    bool time_estimated = false;
};

Extracted skip(std::string why) {
    Extracted e;
    e.skipped = std::move(why);
    return e;
}

Extracted transport_payload(std::uint8_t protocol, Bytes p) {
    if (protocol == 6) {
        if (p.size() < 20) return skip("TCP header cut short");
        const std::size_t header = std::size_t{static_cast<std::uint8_t>(p[12] >> 4)} * 4;
        if (header < 20 || header > p.size()) return skip("TCP header cut short");
        if (header == p.size()) return skip("TCP segments without data");
        return {p.subspan(header), channel_for_ports(be16(p, 0), be16(p, 2)), {}};
    }
    if (protocol == 17) {
        if (p.size() < 8) return skip("UDP header cut short");
        const std::size_t length = std::min<std::size_t>(be16(p, 4), p.size());
        if (length <= 8) return skip("UDP datagrams without data");
        return {p.subspan(8, length - 8), channel_for_ports(be16(p, 0), be16(p, 2)), {}};
    }
    return skip("IP packets that are not TCP or UDP");
}

Extracted ip_payload(Bytes ip) {
    if (ip.empty()) return skip("packets too short for IP");
    const int version = ip[0] >> 4;
    if (version == 4) {
        const std::size_t header = std::size_t{static_cast<std::uint8_t>(ip[0] & 0x0FU)} * 4;
        if (ip.size() < 20 || header < 20 || header > ip.size()) return skip("bad IPv4 headers");
        // Ethernet pads short packets; the IP length says where the packet ends.
        const std::size_t total = std::min<std::size_t>(be16(ip, 2), ip.size());
        if (total < header) return skip("bad IPv4 headers");
        if ((be16(ip, 6) & 0x3FFFU) != 0) return skip("IP fragments (not reassembled)");
        return transport_payload(ip[9], ip.subspan(header, total - header));
    }
    if (version == 6) {
        if (ip.size() < 40) return skip("bad IPv6 headers");
        const std::size_t total = std::min<std::size_t>(40 + std::size_t{be16(ip, 4)}, ip.size());
        std::uint8_t next = ip[6];
        std::size_t at = 40;
        // Hop-by-hop, routing and destination options may come before TCP or UDP.
        while (next == 0 || next == 43 || next == 60) {
            if (at + 2 > total) return skip("bad IPv6 headers");
            const std::size_t length = (std::size_t{ip[at + 1]} + 1) * 8;
            next = ip[at];
            at += length;
            if (at > total) return skip("bad IPv6 headers");
        }
        if (next == 44) return skip("IP fragments (not reassembled)");
        return transport_payload(next, ip.subspan(at, total - at));
    }
    return skip("packets that are not IPv4 or IPv6");
}

Extracted ether_payload(std::uint16_t type, Bytes rest) {
    if (type == 0x0800 || type == 0x86DD) return ip_payload(rest);
    return skip("packets that are not IP (ARP and the like)");
}

Result<Extracted> exported_pdu_payload(Bytes p, std::uint64_t number) {
    std::size_t at = 0;
    std::string_view name;
    std::uint32_t src = 0;
    std::uint32_t dst = 0;
    Nanos duration = kNoTime;
    bool estimated = false;
    for (;;) {
        if (at + 4 > p.size()) {
            return Error{fmt::format("packet {}: exported-PDU tags without an end tag", number)};
        }
        const std::uint16_t tag = be16(p, at);
        const std::size_t length = be16(p, at + 2);
        at += 4;
        if (at + length > p.size()) {
            return Error{fmt::format("packet {}: exported-PDU tag {} runs past the packet end",
                                     number, tag)};
        }
        const Bytes value = p.subspan(at, length);
        at += length;
        if (tag == kTagEndOfOpt) break;
        if (tag == kTagDissectorName || tag == kTagHeuristicName) {
            name = std::string_view(reinterpret_cast<const char*>(value.data()), value.size());
            name = name.substr(0, name.find_last_not_of('\0') + 1);  // the padding
        } else if (tag == kTagSrcPort && length >= 4) {
            src = be32(value, 0);
        } else if (tag == kTagDstPort && length >= 4) {
            dst = be32(value, 0);
        } else if (tag == kTagFrameTiming && length == 8) {
            const std::uint64_t timing = (std::uint64_t{be32(value, 0)} << 32U) | be32(value, 4);
            const std::uint64_t ns = timing & ~kTimeEstimated;
            // Longer than any frame at any rate (256 bytes at 50 baud take 57 s): not ours.
            if (ns <= std::uint64_t{60} * kNanosPerSecond) {
                duration = static_cast<Nanos>(ns);
                estimated = (timing & kTimeEstimated) != 0;
            }
        }
    }
    // "mbrtu" (over TCP) and "mbrtu_udp" hold whole RTU frames. "modbus" and "mbtcp"
    // hold PDUs without address and CRC, which are not RTU frames.
    if (!name.starts_with("mbrtu")) {
        return skip(
            fmt::format("exported PDUs for another dissector ({})", detail::quote_token(name)));
    }
    if (at == p.size()) return skip("exported PDUs without data");
    return Extracted{p.subspan(at), channel_for_ports(src, dst), {}, duration, estimated};
}

// The frame in one packet of link type `dlt`.
Result<Extracted> read_packet(int dlt, Bytes p, std::uint64_t number) {
    if (dlt == kLinktypeUpperPdu) return exported_pdu_payload(p, number);
    if (dlt == kLinktypeRtacSerial) {
        // The event type says whether the RTAC port sent or received the bytes, which is
        // not whether the master or a slave did: the port may be either. No channel.
        if (p.size() <= kRtacHeaderBytes) return skip("RTAC serial events without data");
        return Extracted{p.subspan(kRtacHeaderBytes), {}, {}};
    }
    if (dlt >= kDltUser0 && dlt <= kDltUser15) {
        if (p.empty()) return skip("empty packets");
        return Extracted{p, {}, {}};
    }
    switch (dlt) {
        case kDltEthernet: {
            if (p.size() < 14) return skip("packets too short for Ethernet");
            std::size_t at = 12;
            std::uint16_t type = be16(p, at);
            // VLAN tags (802.1Q, 802.1ad, old QinQ).
            while ((type == 0x8100 || type == 0x88A8 || type == 0x9100) && at + 6 <= p.size()) {
                at += 4;
                type = be16(p, at);
            }
            return ether_payload(type, p.subspan(at + 2));
        }
        case kDltLinuxSll:
            if (p.size() < 16) return skip("packets too short for Linux cooked headers");
            return ether_payload(be16(p, 14), p.subspan(16));
        case kDltLinuxSll2:
            if (p.size() < 20) return skip("packets too short for Linux cooked headers");
            return ether_payload(be16(p, 0), p.subspan(20));
        case kDltNull:
        case kDltLoop:
            // A 4-byte address family in either byte order; the IP version says it all.
            if (p.size() < 4) return skip("packets too short for loopback headers");
            return ip_payload(p.subspan(4));
        default:
            return ip_payload(p);
    }
}

// The bytes format detection took from a pipe, then the rest of the pipe.
struct ChainCookie {
    std::string head;
    std::size_t pos = 0;
    std::FILE* rest = nullptr;
    bool close_rest = false;
};

ssize_t chain_read(void* cookie, char* buf, std::size_t size) {
    auto* c = static_cast<ChainCookie*>(cookie);
    if (c->pos < c->head.size()) {
        const std::size_t n = std::min(size, c->head.size() - c->pos);
        // Binary bytes, not a C string: no terminator belongs here.
        // NOLINTNEXTLINE(bugprone-not-null-terminated-result)
        std::memcpy(buf, c->head.data() + c->pos, n);
        c->pos += n;
        return static_cast<ssize_t>(n);
    }
    if (c->rest == nullptr) return 0;
    const std::size_t n = std::fread(buf, 1, size, c->rest);
    if (n == 0 && std::ferror(c->rest) != 0) return -1;
    return static_cast<ssize_t>(n);
}

int chain_close(void* cookie) {
    auto* c = static_cast<ChainCookie*>(cookie);
    int rc = 0;
    if (c->close_rest && c->rest != nullptr) rc = std::fclose(c->rest);
    delete c;
    return rc;
}

class PcapSource final : public ChunkSource {
  public:
    // `read_buffer` is the stream's stdio buffer: kept until pcap_close has closed it.
    PcapSource(pcap_t* pcap, std::unique_ptr<char[]> read_buffer, std::string name)
        : pcap_(pcap), read_buffer_(std::move(read_buffer)), dlt_(pcap_datalink(pcap)) {
        info_.name = std::move(name);
        info_.format = "pcap";
        info_.timed = true;
        info_.chunk_time_is_start = true;  // rtuscope and Wireshark stamp frame starts
        // Unix time, unless the numbers are too small for it: a pcap written from a
        // capture with relative times. The first packet tells.
        first_ = read_chunk(pending_);
        if (first_ && *first_) info_.time_base = time_base_of(pending_.time);
    }
    ~PcapSource() override { pcap_close(pcap_); }
    PcapSource(const PcapSource&) = delete;
    PcapSource& operator=(const PcapSource&) = delete;

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
        std::vector<std::string> out;
        if (!cut_off_.empty()) out.push_back(cut_off_);
        for (const auto& [why, count] : skipped_) {
            out.push_back(fmt::format("skipped {} of {} packets: {}", count, packets_, why));
        }
        if (skipped_otherwise_ != 0) {
            out.push_back(fmt::format("skipped {} of {} packets: other reasons (more than {})",
                                      skipped_otherwise_, packets_, kMaxSkipReasons));
        }
        return out;
    }

  private:
    // The next packet that holds a frame, as a chunk; false at the end of the file.
    Result<bool> read_chunk(Chunk& out) {
        for (;;) {
            pcap_pkthdr* header = nullptr;
            const u_char* data = nullptr;
            const int rc = pcap_next_ex(pcap_, &header, &data);
            if (rc == PCAP_ERROR_BREAK) return false;  // end of file
            if (rc != 1) {
                const std::string why = pcap_geterr(pcap_);
                // A file cut off in its last packet (a capture killed or still being written)
                // reads as far as it goes, as tshark reads it; a broken one stops here.
                if (why.starts_with("truncated")) {
                    cut_off_ = fmt::format(
                        "the file ends inside packet {} (cut off before it was complete); "
                        "{} packets read",
                        packets_ + 1, packets_);
                    return false;
                }
                return Error{fmt::format("packet {}: {}", packets_ + 1, why), info_.name};
            }
            ++packets_;
            Result<Extracted> got = read_packet(dlt_, Bytes(data, header->caplen), packets_);
            if (!got) return Error{got.error().message, info_.name};
            if (!got->skipped.empty()) {
                if (skipped_.size() < kMaxSkipReasons || skipped_.contains(got->skipped)) {
                    ++skipped_[got->skipped];
                } else {
                    ++skipped_otherwise_;
                }
                continue;
            }
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
                                         static_cast<std::int64_t>(header->ts.tv_sec)),
                             info_.name};
            }
            out.time = time;
            if (out.channel != got->channel) out.channel = got->channel;
            out.bytes.assign(got->frame.begin(), got->frame.end());
            out.source_line = 0;
            out.char_errors.clear();
            out.whole_frame = true;  // one packet, one frame
            out.duration = got->duration;
            out.time_estimated = got->time_estimated;
            return true;
        }
    }

    pcap_t* pcap_;
    std::unique_ptr<char[]> read_buffer_;
    std::string cut_off_;  // the remark for a file cut off in its last packet
    int dlt_;
    SourceInfo info_;
    // Reasons are counted apart up to a bound: each dissector name is one, and a crafted
    // file could hold millions of them.
    static constexpr std::size_t kMaxSkipReasons = 32;
    std::uint64_t packets_ = 0;
    std::map<std::string, std::uint64_t> skipped_;
    std::uint64_t skipped_otherwise_ = 0;  // for reasons beyond kMaxSkipReasons
    // The first packet, read ahead for the time base, and what reading it gave.
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

Result<std::unique_ptr<ChunkSource>> pcap_source_from_stream(std::string head, std::FILE* rest,
                                                             bool close_rest, std::string name) {
    // A file of ours whose head was read from its own start (it stands just past the head)
    // and that can go back there is libpcap's to read as it is: through the chain below,
    // every packet's reads would take glibc's slow generic path.
    std::FILE* stream = nullptr;
    const long position = rest != nullptr ? std::ftell(rest) : -1;
    if (close_rest && position >= 0 && static_cast<std::size_t>(position) == head.size() &&
        std::fseek(rest, 0, SEEK_SET) == 0) {
        stream = rest;
    } else {
        auto* cookie = new ChainCookie{std::move(head), 0, rest, close_rest};
        const cookie_io_functions_t io{chain_read, nullptr, nullptr, chain_close};
        stream = fopencookie(cookie, "rb", io);
        if (stream == nullptr) {
            const int err = errno;
            chain_close(cookie);
            return Error{fmt::format("cannot read: {}", std::strerror(err)), name};
        }
    }
    // libpcap reads each packet with two small freads: with stdio's own 4 KiB buffer, a
    // read() every ~60 packets of ours. Set before libpcap's first read; the file taken
    // as it is has been seeked back to its start, its buffer empty.
    auto read_buffer = give_stdio_buffer(stream);
    char errbuf[PCAP_ERRBUF_SIZE] = {};
    pcap_t* pcap =
        pcap_fopen_offline_with_tstamp_precision(stream, PCAP_TSTAMP_PRECISION_NANO, errbuf);
    if (pcap == nullptr) {
        std::fclose(stream);  // not taken over on failure
        return Error{fmt::format("not a pcap or pcapng file rtuscope can read: {}", errbuf), name};
    }
    const int dlt = pcap_datalink(pcap);
    if (!supported_link_type(dlt)) {
        pcap_close(pcap);
        return Error{fmt::format("link type {} is not one rtuscope reads (252, 250, 147-162, "
                                 "Ethernet/IP with Modbus RTU over TCP/UDP)",
                                 dlt),
                     name};
    }
    return std::unique_ptr<ChunkSource>(
        std::make_unique<PcapSource>(pcap, std::move(read_buffer), std::move(name)));
}

Result<std::unique_ptr<ChunkSource>> pcap_source_from_memory(std::string content,
                                                             std::string name) {
    return pcap_source_from_stream(std::move(content), nullptr, false, std::move(name));
}

Result<std::unique_ptr<ChunkSource>> open_pcap_source(const std::string& path) {
    return open_source(path, InputFormat::pcap);
}

}  // namespace rtuscope
