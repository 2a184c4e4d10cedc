// Packets to chunks: which part of a packet holds Modbus RTU depends on its link type
// (read_packet()); TCP and UDP payloads go through the flows (ip_flows.hpp) first.
#include "input/pcap_packets.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <utility>

#include "framing/frame.hpp"
#include "input/mbap.hpp"
#include "input/pcap.hpp"
#include "input/readers.hpp"

namespace rtuscope::pcap {
namespace {

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

constexpr std::uint8_t kTcp = 6;
constexpr std::uint8_t kUdp = 17;

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

std::string_view channel_for_ports(std::uint32_t src, std::uint32_t dst) {
    if (dst == kModbusPort && src != kModbusPort) return "master";
    if (src == kModbusPort && dst != kModbusPort) return "slave";
    return {};
}

// What one packet holds: its Modbus RTU bytes and their direction, a TCP segment or a UDP
// datagram for the flows, or why there is nothing (counted in the remarks); or an Error
// for a packet that is broken where it should not be.
struct Extracted {
    Bytes bytes;               // the frame, the packet's RTU bytes, or the TCP/UDP payload
    std::string_view channel;  // "master", "slave" or none
    std::string skipped;       // non-empty: nothing to read, and why
    Nanos duration = kNoTime;  // the frame's time on the line, when the packet says
    bool time_estimated = false;
    bool framed = false;         // an exported PDU: one frame, as a dissector cut it
    bool modbus_tcp = false;     // an exported PDU for mbtcp: one Modbus/TCP ADU
    std::uint8_t transport = 0;  // kTcp, kUdp, or 0: the bytes are serial data
    FlowKey flow;
    TcpSegment tcp;
    // The payload's length as the headers give it, when they do (TCP and UDP): more than
    // bytes.size() when the capture's snap length cut the packet.
    std::size_t length = 0;
};

Extracted skip(std::string why) {
    Extracted e;
    e.skipped = std::move(why);
    return e;
}

// `p`: the IP payload as captured; `length`: as the IP header gives it.
Extracted transport_payload(std::uint8_t protocol, Bytes p, std::size_t length, FlowKey flow) {
    flow.protocol = protocol;
    if (protocol == kTcp) {
        if (p.size() < 20) return skip("TCP header cut short");
        const std::size_t header = std::size_t{static_cast<std::uint8_t>(p[12] >> 4)} * 4;
        if (header < 20 || header > p.size()) return skip("TCP header cut short");
        Extracted e;
        e.transport = kTcp;
        e.bytes = p.subspan(header);
        e.length = std::max(length, p.size()) - header;
        flow.source_port = be16(p, 0);
        flow.destination_port = be16(p, 2);
        e.tcp.sequence = be32(p, 4);
        const std::uint8_t flags = p[13];
        e.tcp.fin = (flags & 0x01U) != 0;
        e.tcp.syn = (flags & 0x02U) != 0;
        e.tcp.rst = (flags & 0x04U) != 0;
        e.tcp.payload_length = static_cast<std::uint32_t>(std::min<std::size_t>(e.length, 0xFFFF));
        e.channel = channel_for_ports(flow.source_port, flow.destination_port);
        e.flow = flow;
        return e;
    }
    if (protocol == kUdp) {
        if (p.size() < 8) return skip("UDP header cut short");
        const std::size_t udp_length = be16(p, 4);
        if (udp_length < 8) return skip("UDP datagrams without data");
        Extracted e;
        e.transport = kUdp;
        e.bytes = p.subspan(8, std::min(udp_length, p.size()) - 8);
        e.length = udp_length - 8;
        if (e.length == 0) return skip("UDP datagrams without data");
        flow.source_port = be16(p, 0);
        flow.destination_port = be16(p, 2);
        e.channel = channel_for_ports(flow.source_port, flow.destination_port);
        e.flow = flow;
        return e;
    }
    return skip("IP packets that are not TCP or UDP");
}

Extracted ip_payload(Bytes ip) {
    if (ip.empty()) return skip("packets too short for IP");
    const int version = ip[0] >> 4;
    FlowKey flow;
    if (version == 4) {
        const std::size_t header = std::size_t{static_cast<std::uint8_t>(ip[0] & 0x0FU)} * 4;
        if (ip.size() < 20 || header < 20 || header > ip.size()) return skip("bad IPv4 headers");
        // Ethernet pads short packets; the IP length says where the packet ends. A
        // capture's snap length may have cut it before.
        const std::size_t claimed = be16(ip, 2);
        const std::size_t total = std::min<std::size_t>(claimed, ip.size());
        if (total < header) return skip("bad IPv4 headers");
        if ((be16(ip, 6) & 0x3FFFU) != 0) return skip("IP fragments (not reassembled)");
        flow.ip_version = 4;
        std::copy_n(ip.begin() + 12, 4, flow.source.begin());
        std::copy_n(ip.begin() + 16, 4, flow.destination.begin());
        return transport_payload(ip[9], ip.subspan(header, total - header), claimed - header,
                                 flow);
    }
    if (version == 6) {
        if (ip.size() < 40) return skip("bad IPv6 headers");
        const std::size_t claimed = 40 + std::size_t{be16(ip, 4)};
        const std::size_t total = std::min<std::size_t>(claimed, ip.size());
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
        flow.ip_version = 6;
        std::copy_n(ip.begin() + 8, 16, flow.source.begin());
        std::copy_n(ip.begin() + 24, 16, flow.destination.begin());
        return transport_payload(next, ip.subspan(at, total - at), claimed - at, flow);
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
    // "mbrtu" (over TCP) and "mbrtu_udp" hold whole RTU frames, "mbtcp" a Modbus/TCP ADU.
    // "modbus" holds a PDU alone: no unit, no transaction.
    const bool modbus_tcp = name == "mbtcp";
    if (modbus_tcp && mbap_adu_length(p.subspan(at)) != p.size() - at) {
        return skip("exported Modbus/TCP PDUs that are no ADU");
    }
    if (!name.starts_with("mbrtu") && !modbus_tcp) {
        return skip(
            fmt::format("exported PDUs for another dissector ({})", detail::quote_token(name)));
    }
    if (at == p.size()) return skip("exported PDUs without data");
    Extracted e;
    e.bytes = p.subspan(at);
    e.channel = channel_for_ports(src, dst);
    e.duration = duration;
    e.time_estimated = estimated;
    e.framed = true;
    e.modbus_tcp = modbus_tcp;
    e.flow.source_port = static_cast<std::uint16_t>(src);
    e.flow.destination_port = static_cast<std::uint16_t>(dst);
    return e;
}

// What one packet of link type `link_type` holds.
Result<Extracted> read_packet(int link_type, Bytes p, std::uint64_t number) {
    if (link_type == kLinktypeUpperPdu) return exported_pdu_payload(p, number);
    if (link_type == kLinktypeRtacSerial) {
        // The event type says whether the RTAC port sent or received the bytes, which is
        // not whether the master or a slave did: the port may be either. No channel.
        if (p.size() <= kRtacHeaderBytes) return skip("RTAC serial events without data");
        Extracted e;
        e.bytes = p.subspan(kRtacHeaderBytes);
        return e;
    }
    if (link_type >= kDltUser0 && link_type <= kDltUser15) {
        if (p.empty()) return skip("empty packets");
        Extracted e;
        e.bytes = p;
        return e;
    }
    switch (link_type) {
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

}  // namespace

bool supported_link_type(int link_type) {
    switch (link_type) {
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
            return link_type >= kDltUser0 && link_type <= kDltUser15;
    }
}

PacketChunker::PacketChunker(const PcapOptions& options) : flows_(*this, options.rtu_ports) {}

Status PacketChunker::add(const Packet& packet, std::uint64_t number) {
    ++packets_;
    if (!supported_link_type(packet.link_type)) {
        if (unsupported_link_types_.size() < kMaxLinkTypesCounted ||
            unsupported_link_types_.contains(packet.link_type)) {
            ++unsupported_link_types_[packet.link_type];
        } else {
            ++unsupported_otherwise_;
        }
        return ok_status();
    }
    Result<Extracted> got = read_packet(packet.link_type, packet.data, number);
    if (!got) return got.error();
    Extracted& e = *got;
    if (!e.skipped.empty()) {
        skip(e.skipped);
        return ok_status();
    }
    packet_time_ = packet.time;
    if (e.framed && packet.direction != PacketDirection::unknown) {
        const std::string_view flagged =
            packet.direction == PacketDirection::outbound ? "master" : "slave";
        if (!e.channel.empty() && e.channel != flagged) ++direction_disagreements_;
        e.channel = flagged;
    }
    // The bytes of the packet the capture did not keep, past the ones read. Only then do
    // the IP and UDP lengths say more than the bytes hold; otherwise they lie.
    const std::size_t cut =
        packet.length > packet.data.size() ? packet.length - packet.data.size() : 0;
    if (cut != 0) ++cut_by_snaplen_;
    if (cut == 0) {
        e.length = e.bytes.size();
        e.tcp.payload_length = static_cast<std::uint32_t>(e.bytes.size());
    }
    const std::size_t payload_cut =
        e.transport != 0 ? std::min(cut, e.length - std::min(e.length, e.bytes.size())) : cut;
    const auto not_captured =
        static_cast<std::uint32_t>(std::min<std::size_t>(payload_cut, 0xFFFFFFFF));
    if (e.transport == kTcp) {
        if (e.tcp.payload_length == 0) skip("TCP segments without data");
        flows_.tcp(e.flow, e.tcp, e.bytes, packet.time, e.channel);
        return ok_status();
    }
    if (e.transport == kUdp) {
        flows_.udp(e.flow, e.bytes, not_captured, packet.time, e.channel);
        return ok_status();
    }
    // The packet's comments go with the frame it is, not with a stream's bytes.
    packet_comments_ = packet.comments;
    if (e.modbus_tcp) {
        if (not_captured == 0) modbus_tcp(e.bytes, packet.time, e.time_estimated, e.channel, e.flow);
    } else {
        emit(e.bytes, packet.time, e.time_estimated, e.channel, not_captured, e.framed,
             e.duration);
    }
    packet_comments_ = {};
    return ok_status();
}

void PacketChunker::finish() {
    packet_time_ = kNoTime;
    flows_.finish();
}

void PacketChunker::rtu(Bytes bytes, Nanos time, bool time_estimated, std::string_view channel,
                        std::uint32_t not_captured) {
    emit(bytes, time, time_estimated, channel, not_captured, false, kNoTime);
}

void PacketChunker::skipped(IpFlows::Skip why, const FlowKey& flow, std::uint64_t packets) {
    switch (why) {
        case IpFlows::Skip::retransmission:
            retransmissions_ += packets;
            return;
        case IpFlows::Skip::not_modbus: {
            not_modbus_ += packets;
            // Where a server listens: the lower port, as a rule.
            const std::uint16_t port = std::min(flow.source_port, flow.destination_port);
            if (not_modbus_ports_.size() < kMaxPortsCounted || not_modbus_ports_.contains(port)) {
                not_modbus_ports_[port] += packets;
            }
            return;
        }
    }
}

Chunk& PacketChunker::next_chunk(Nanos& time, bool& time_estimated, std::string_view channel) {
    // Bytes held for the rest of a frame come out after other flows' later packets: they
    // follow those, estimated, so that the input's time never seems to go back.
    if (has_time(time) && has_time(last_emitted_) && time < last_emitted_ &&
        (!has_time(packet_time_) || time < packet_time_)) {
        time = last_emitted_;
        time_estimated = true;
    }
    if (has_time(time)) last_emitted_ = time;
    if (size_ == queue_.size()) queue_.emplace_back();
    Chunk& out = queue_[size_++];
    out.time = time;
    out.time_estimated = time_estimated;
    if (out.channel != channel) out.channel = channel;
    out.source_line = 0;
    out.char_errors.clear();
    out.bytes_not_captured = 0;
    out.duration = kNoTime;
    out.transport = Transport::rtu;
    out.mbap = {};
    out.comments.clear();
    return out;
}

void PacketChunker::keep_comments(Chunk& out) const {
    for (const std::string_view comment : packet_comments_) {
        if (!comment.starts_with(kOwnCommentPrefix)) out.comments.emplace_back(comment);
    }
}

void PacketChunker::modbus_tcp(Bytes adu, Nanos time, bool time_estimated,
                               std::string_view channel, const FlowKey& flow) {
    Chunk& out = next_chunk(time, time_estimated, channel);
    // The frame: the unit id and the PDU; the header's transaction id and the connection
    // (its flows either way, the same number) beside it.
    out.bytes.assign(adu.begin() + kMbapHeaderBytes - 1, adu.end());
    out.whole_frame = true;
    out.packet = false;
    out.transport = Transport::tcp;
    out.mbap.transaction = be16(adu, 0);
    const FlowKey reversed = flow.reversed();
    const FlowKeyHash hash;
    out.mbap.connection =
        static_cast<std::uint32_t>(hash(flow) ^ hash(reversed)) | 1U;  // never 0
    keep_comments(out);
}

void PacketChunker::emit(Bytes bytes, Nanos time, bool time_estimated, std::string_view channel,
                         std::uint32_t not_captured, bool framed, Nanos duration) {
    if (bytes.empty()) return;
    Chunk& out = next_chunk(time, time_estimated, channel);
    out.bytes.assign(bytes.begin(), bytes.end());
    // An exported PDU is a frame as a dissector cut it; another packet is one frame when
    // its length and CRC say so, else bytes for the framer to cut.
    out.whole_frame =
        not_captured == 0 &&
        (framed || (!time_estimated && is_whole_frame(out.bytes, standard_rules())));
    out.packet = !out.whole_frame;
    out.bytes_not_captured = not_captured;
    out.duration = out.whole_frame ? duration : kNoTime;
    if (out.whole_frame) keep_comments(out);
}

bool PacketChunker::pop(Chunk& out) {
    if (head_ == size_) return false;
    std::swap(out, queue_[head_++]);
    if (head_ == size_) head_ = size_ = 0;
    return true;
}

void PacketChunker::skip(const std::string& why) {
    if (skipped_.size() < kMaxSkipReasons || skipped_.contains(why)) {
        ++skipped_[why];
    } else {
        ++skipped_otherwise_;
    }
}

std::vector<std::string> PacketChunker::remarks(bool cut_off) const {
    std::vector<std::string> out;
    if (cut_off) {
        out.push_back(fmt::format(
            "the file ends inside packet {} (cut off before it was complete); {} packets read",
            packets_ + 1, packets_));
    }
    for (const auto& [why, count] : skipped_) {
        out.push_back(fmt::format("skipped {} of {} packets: {}", count, packets_, why));
    }
    if (skipped_otherwise_ != 0) {
        out.push_back(fmt::format("skipped {} of {} packets: other reasons (more than {})",
                                  skipped_otherwise_, packets_, kMaxSkipReasons));
    }
    if (retransmissions_ != 0) {
        out.push_back(fmt::format(
            "skipped {} of {} packets: TCP retransmissions (their bytes read once)",
            retransmissions_, packets_));
    }
    if (not_modbus_ != 0) {
        // The busiest ports first, a few of them.
        std::vector<std::pair<std::uint64_t, std::uint16_t>> ports;
        for (const auto& [port, count] : not_modbus_ports_) ports.emplace_back(count, port);
        std::sort(ports.begin(), ports.end(), [](const auto& a, const auto& b) {
            return a.first != b.first ? a.first > b.first : a.second < b.second;
        });
        constexpr std::size_t kShown = 5;
        std::string shown;
        for (std::size_t i = 0; i < ports.size() && i < kShown; ++i) {
            shown += fmt::format("{}{}", i == 0 ? "" : ", ", ports[i].second);
        }
        if (ports.size() > kShown) shown += ", ...";
        out.push_back(fmt::format(
            "skipped {} of {} packets: TCP and UDP payloads that are neither Modbus RTU nor "
            "Modbus/TCP ({} {})",
            not_modbus_, packets_, ports.size() == 1 ? "port" : "ports", shown));
    }
    if (!unsupported_link_types_.empty() || unsupported_otherwise_ != 0) {
        std::uint64_t total = unsupported_otherwise_;
        std::string each;
        for (const auto& [link_type, count] : unsupported_link_types_) {
            total += count;
            each += fmt::format("{}{} of link type {}", each.empty() ? "" : ", ", count, link_type);
        }
        if (unsupported_otherwise_ != 0) {
            each += fmt::format(", {} of other link types", unsupported_otherwise_);
        }
        out.push_back(fmt::format(
            "skipped {} of {} packets: interfaces whose link type carries no Modbus RTU ({})",
            total, packets_, each));
    }
    if (cut_by_snaplen_ != 0) {
        out.push_back(fmt::format(
            "{} of {} packets {} cut by the capture's snap length: their last bytes are "
            "missing (no error of the bus)",
            cut_by_snaplen_, packets_, cut_by_snaplen_ == 1 ? "was" : "were"));
    }
    if (direction_disagreements_ != 0) {
        out.push_back(fmt::format(
            "{} of {} packets: their direction flags disagree with their ports; the flags "
            "are taken",
            direction_disagreements_, packets_));
    }
    for (std::string& remark : flows_.remarks()) out.push_back(std::move(remark));
    return out;
}

}  // namespace rtuscope::pcap
