// Helpers of the pcap tests: pcap and pcapng files built byte by byte (link-layer, IP, TCP
// and UDP headers, pcapng blocks of either byte order), and a source drained of its
// chunks.
#pragma once

#include <algorithm>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "input/chunk.hpp"
#include "support.hpp"
#include "util/time.hpp"

namespace rtuscope::test {

inline void put16(std::string& out, std::uint16_t v, bool big) {
    if (big) {
        out += static_cast<char>(v >> 8);
        out += static_cast<char>(v & 0xFF);
    } else {
        out += static_cast<char>(v & 0xFF);
        out += static_cast<char>(v >> 8);
    }
}

inline void put32(std::string& out, std::uint32_t v, bool big = false) {
    if (big) {
        put16(out, static_cast<std::uint16_t>(v >> 16), true);
        put16(out, static_cast<std::uint16_t>(v), true);
    } else {
        put16(out, static_cast<std::uint16_t>(v), false);
        put16(out, static_cast<std::uint16_t>(v >> 16), false);
    }
}

inline std::string str(const Bytes& b) {
    return {b.begin(), b.end()};
}

struct Packet {
    Nanos time;
    Bytes data;
    // Its length on the wire; 0: the bytes' (the snap length did not cut it).
    std::uint32_t length = 0;
};

// A classic pcap file, microsecond timestamps, little-endian.
inline std::string pcap_file(std::uint32_t linktype, const std::vector<Packet>& packets) {
    std::string out;
    put32(out, 0xA1B2C3D4);
    put16(out, 2, false);
    put16(out, 4, false);
    put32(out, 0);
    put32(out, 0);
    put32(out, 65535);
    put32(out, linktype);
    for (const Packet& p : packets) {
        put32(out, static_cast<std::uint32_t>(p.time / kNanosPerSecond));
        put32(out, static_cast<std::uint32_t>(p.time % kNanosPerSecond / 1000));
        put32(out, static_cast<std::uint32_t>(p.data.size()));
        put32(out, p.length != 0 ? p.length : static_cast<std::uint32_t>(p.data.size()));
        out += str(p.data);
    }
    return out;
}

// A pcapng file block by block, in either byte order.
class Pcapng {
  public:
    explicit Pcapng(bool big_endian = false) : big_(big_endian) { section(); }

    // Another section header (a new section forgets the interfaces before it).
    Pcapng& section() {
        std::string body;
        put32(body, 0x1A2B3C4D, big_);
        put16(body, 1, big_);
        put16(body, 0, big_);
        put32(body, 0xFFFFFFFF, big_);
        put32(body, 0xFFFFFFFF, big_);
        return block(0x0A0D0D0A, body);
    }
    // An interface; `resolution`: the if_tsresol byte, none for microseconds;
    // `offset_seconds`: if_tsoffset.
    Pcapng& interface(std::uint16_t linktype, std::optional<std::uint8_t> resolution = {},
                      std::optional<std::int64_t> offset_seconds = {},
                      std::uint32_t snap_length = 65535) {
        std::string body;
        put16(body, linktype, big_);
        put16(body, 0, big_);
        put32(body, snap_length, big_);
        if (resolution) {
            put16(body, 9, big_);
            put16(body, 1, big_);
            body += static_cast<char>(*resolution);
            body.append(3, '\0');
        }
        if (offset_seconds) {
            put16(body, 14, big_);
            put16(body, 8, big_);
            const auto v = static_cast<std::uint64_t>(*offset_seconds);
            put32(body, static_cast<std::uint32_t>(big_ ? v >> 32 : v), big_);
            put32(body, static_cast<std::uint32_t>(big_ ? v : v >> 32), big_);
        }
        if (resolution || offset_seconds) put32(body, 0, big_);  // opt_endofopt
        return block(1, body);
    }
    // An enhanced packet block; `units`: the time in the interface's unit.
    Pcapng& packet(std::uint32_t interface, std::uint64_t units, const Bytes& data,
                   std::uint32_t length = 0) {
        std::string body;
        put32(body, interface, big_);
        put32(body, static_cast<std::uint32_t>(units >> 32), big_);
        put32(body, static_cast<std::uint32_t>(units), big_);
        put32(body, static_cast<std::uint32_t>(data.size()), big_);
        put32(body, length != 0 ? length : static_cast<std::uint32_t>(data.size()), big_);
        body += padded(data);
        return block(6, body);
    }
    // A simple packet block (interface 0, no time).
    Pcapng& simple_packet(const Bytes& data) {
        std::string body;
        put32(body, static_cast<std::uint32_t>(data.size()), big_);
        body += padded(data);
        return block(3, body);
    }
    // An obsolete packet block.
    Pcapng& obsolete_packet(std::uint16_t interface, std::uint64_t units, const Bytes& data) {
        std::string body;
        put16(body, interface, big_);
        put16(body, 0, big_);
        put32(body, static_cast<std::uint32_t>(units >> 32), big_);
        put32(body, static_cast<std::uint32_t>(units), big_);
        put32(body, static_cast<std::uint32_t>(data.size()), big_);
        put32(body, static_cast<std::uint32_t>(data.size()), big_);
        body += padded(data);
        return block(2, body);
    }
    // Any block: its type and body (padded to 4 here).
    Pcapng& block(std::uint32_t type, std::string body) {
        body.append((4 - body.size() % 4) % 4, '\0');
        const auto length = static_cast<std::uint32_t>(body.size() + 12);
        put32(out_, type, big_);
        put32(out_, length, big_);
        out_ += body;
        put32(out_, length, big_);
        return *this;
    }
    [[nodiscard]] const std::string& str() const { return out_; }

  private:
    static std::string padded(const Bytes& data) {
        std::string s(data.begin(), data.end());
        s.append((4 - s.size() % 4) % 4, '\0');
        return s;
    }
    bool big_;
    std::string out_;
};

// A pcapng file: section header, one interface (microsecond resolution), enhanced
// packet blocks.
inline std::string pcapng_file(std::uint16_t linktype, const std::vector<Packet>& packets) {
    Pcapng file;
    file.interface(linktype);
    for (const Packet& p : packets) {
        file.packet(0, static_cast<std::uint64_t>(p.time / 1000), p.data, p.length);
    }
    return file.str();
}

inline constexpr std::uint8_t kPsh = 0x18;  // PSH and ACK: a segment with data
inline constexpr std::uint8_t kSyn = 0x02;
inline constexpr std::uint8_t kFin = 0x11;  // FIN and ACK

inline Bytes tcp(std::uint16_t src, std::uint16_t dst, const Bytes& payload,
                 std::uint32_t seq = 1, std::uint8_t flags = kPsh) {
    Bytes t = {static_cast<std::uint8_t>(src >> 8),
               static_cast<std::uint8_t>(src),
               static_cast<std::uint8_t>(dst >> 8),
               static_cast<std::uint8_t>(dst),
               static_cast<std::uint8_t>(seq >> 24),
               static_cast<std::uint8_t>(seq >> 16),
               static_cast<std::uint8_t>(seq >> 8),
               static_cast<std::uint8_t>(seq),
               0,
               0,
               0,
               0,
               0x50,
               flags,
               0x10,
               0x00,
               0,
               0,
               0,
               0};
    t.insert(t.end(), payload.begin(), payload.end());
    return t;
}

inline Bytes udp(std::uint16_t src, std::uint16_t dst, const Bytes& payload) {
    const auto length = static_cast<std::uint16_t>(8 + payload.size());
    Bytes u = {static_cast<std::uint8_t>(src >> 8),
               static_cast<std::uint8_t>(src),
               static_cast<std::uint8_t>(dst >> 8),
               static_cast<std::uint8_t>(dst),
               static_cast<std::uint8_t>(length >> 8),
               static_cast<std::uint8_t>(length),
               0,
               0};
    u.insert(u.end(), payload.begin(), payload.end());
    return u;
}

// 10.0.0.1 to 10.0.0.2 (`swapped`: the other way).
inline Bytes ipv4(std::uint8_t protocol, const Bytes& payload, bool swapped = false) {
    const auto length = static_cast<std::uint16_t>(20 + payload.size());
    const std::uint8_t a = swapped ? 2 : 1;
    const std::uint8_t b = swapped ? 1 : 2;
    Bytes ip = {0x45,
                0,
                static_cast<std::uint8_t>(length >> 8),
                static_cast<std::uint8_t>(length),
                0,
                0,
                0x40,
                0,
                64,
                protocol,
                0,
                0,
                10,
                0,
                0,
                a,
                10,
                0,
                0,
                b};
    ip.insert(ip.end(), payload.begin(), payload.end());
    return ip;
}

inline Bytes ipv6(std::uint8_t next, const Bytes& payload) {
    const auto length = static_cast<std::uint16_t>(payload.size());
    Bytes ip = {
        0x60, 0, 0, 0, static_cast<std::uint8_t>(length >> 8), static_cast<std::uint8_t>(length),
        next, 64};
    ip.resize(40, 0);
    ip[23] = 1;
    ip[39] = 2;
    ip.insert(ip.end(), payload.begin(), payload.end());
    return ip;
}

inline Bytes ethernet(std::uint16_t type, const Bytes& payload) {
    Bytes e = {2,
               0,
               0,
               0,
               0,
               1,
               2,
               0,
               0,
               0,
               0,
               2,
               static_cast<std::uint8_t>(type >> 8),
               static_cast<std::uint8_t>(type)};
    e.insert(e.end(), payload.begin(), payload.end());
    if (e.size() < 60) e.resize(60, 0);  // Ethernet's minimum frame, padded
    return e;
}

// An Ethernet frame of a TCP segment from port `src` to port `dst`: from 10.0.0.1 to
// 10.0.0.2, the other way when it comes from port 502.
inline Bytes eth_tcp(std::uint16_t src, std::uint16_t dst, const Bytes& payload,
                     std::uint32_t seq = 1, std::uint8_t flags = kPsh) {
    return ethernet(0x0800, ipv4(6, tcp(src, dst, payload, seq, flags), src == 502));
}

struct Drained {
    std::vector<Chunk> chunks;
    std::optional<Error> error;
    std::vector<std::string> remarks;
};

inline Drained drain(ChunkSource& source) {
    Drained d;
    for (;;) {
        Chunk c;
        Result<bool> more = source.next(c);
        if (!more) {
            d.error = more.error();
            break;
        }
        if (!*more) break;
        d.chunks.push_back(std::move(c));
    }
    d.remarks = source.remarks();
    return d;
}

}  // namespace rtuscope::test
