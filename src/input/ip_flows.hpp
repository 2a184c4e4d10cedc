// Internal to the pcap reader: the TCP and UDP flows of a capture. TCP streams are put
// back in order by sequence number (retransmitted bytes taken once, segments that came
// early held until the gap fills), so that an RTU frame sent over two segments is one
// frame, and so is a Modbus/TCP ADU. Each flow's payloads are told apart by their bytes,
// never by the port: Modbus RTU (frames whose CRC checks), Modbus/TCP (mbap.hpp), or
// neither (S7comm, EtherNet/IP, ...).
// Memory is bounded: so many flows at once, so many bytes held a stream and in all.
#pragma once

#include <array>
#include <cstdint>
#include <list>
#include <map>
#include <span>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "util/time.hpp"

namespace rtuscope {

// One direction of a TCP connection or of a UDP exchange.
struct FlowKey {
    std::array<std::uint8_t, 16> source{};  // IPv4 addresses in the first 4 bytes
    std::array<std::uint8_t, 16> destination{};
    std::uint16_t source_port = 0;
    std::uint16_t destination_port = 0;
    std::uint8_t protocol = 0;  // 6 TCP, 17 UDP
    std::uint8_t ip_version = 0;

    bool operator==(const FlowKey&) const = default;
    [[nodiscard]] FlowKey reversed() const;
};

struct FlowKeyHash {
    std::size_t operator()(const FlowKey& key) const;
};

// What a TCP segment says besides its payload.
struct TcpSegment {
    std::uint32_t sequence = 0;
    bool syn = false;
    bool fin = false;
    bool rst = false;
    // The payload's length as the IP and TCP headers give it: more than the bytes
    // captured when the capture's snap length cut the packet.
    std::uint32_t payload_length = 0;
};

class IpFlows {
  public:
    enum class Skip : std::uint8_t {
        retransmission,  // a TCP segment whose bytes were all read before
        not_modbus,      // neither Modbus RTU nor Modbus/TCP
    };
    // Where the flows' Modbus RTU bytes and their skipped packets go.
    class Output {
      public:
        virtual ~Output() = default;
        // Bytes of a flow that carries Modbus RTU, to be framed on their own: a
        // datagram, or a stretch of a stream that begins with a frame (or the flow's first
        // bytes) and ends with one (or where the stream's bytes went missing).
        // `time_estimated`: they began inside an earlier segment, after frames of it.
        // `not_captured`: the capture cut that many bytes after them.
        virtual void rtu(std::span<const std::uint8_t> bytes, Nanos time, bool time_estimated,
                         std::string_view channel, std::uint32_t not_captured) = 0;
        // One Modbus/TCP ADU (MBAP header, unit id, PDU) of a flow that carries them.
        virtual void modbus_tcp(std::span<const std::uint8_t> adu, Nanos time, bool time_estimated,
                                std::string_view channel, const FlowKey& flow) = 0;
        virtual void skipped(Skip why, const FlowKey& flow, std::uint64_t packets) = 0;
    };

    // `rtu_ports`: flows to or from these ports carry Modbus RTU whatever their bytes
    // look like, the port's side the slave's.
    explicit IpFlows(Output& out, std::vector<std::uint16_t> rtu_ports = {})
        : out_(out), rtu_ports_(std::move(rtu_ports)) {}

    // `payload`: the bytes captured; `channel`: the direction the ports say.
    void tcp(const FlowKey& key, const TcpSegment& segment, std::span<const std::uint8_t> payload,
             Nanos time, std::string_view channel);
    void udp(const FlowKey& key, std::span<const std::uint8_t> payload, std::uint32_t not_captured,
             Nanos time, std::string_view channel);
    // The end of the capture: every stream gives what it holds.
    void finish();
    // The bounds that were hit and the bytes the streams missed, if any.
    [[nodiscard]] std::vector<std::string> remarks() const;

    // The bounds (docs/formats.md).
    static constexpr std::size_t kMaxFlows = 4096;
    static constexpr std::size_t kMaxHeldBytesPerStream = std::size_t{64} << 10;
    static constexpr std::size_t kMaxHeldBytes = std::size_t{4} << 20;

  private:
    enum class Protocol : std::uint8_t { unknown, rtu, modbus_tcp, other };
    // Where a segment's bytes begin in a stream's pending bytes, and when they came.
    struct Mark {
        std::size_t at = 0;
        Nanos time = kNoTime;
        bool estimated = false;  // they began inside the segment, after frames of it
    };
    // A segment that came before the bytes in front of it.
    struct Early {
        std::vector<std::uint8_t> bytes;
        Nanos time = kNoTime;
        std::uint32_t length = 0;  // its payload length (more than bytes when cut)
        bool fin = false;
    };
    struct Flow {
        FlowKey key;
        Protocol protocol = Protocol::unknown;
        std::string_view channel;
        bool synced = false;  // next_sequence known
        bool closed = false;  // FIN or RST seen
        std::uint32_t next_sequence = 0;
        std::uint64_t next_offset = 0;  // next_sequence as a count of the stream's bytes
        // In-order bytes not handed on yet: the start of a frame whose end has not come,
        // or a new flow's first bytes until they tell what it carries.
        std::vector<std::uint8_t> pending;
        std::vector<Mark> marks;
        std::map<std::uint64_t, Early> early;  // by stream offset
        std::size_t early_bytes = 0;
        std::list<FlowKey>::iterator recent;  // its place in recent_
    };

    Flow& flow_for(const FlowKey& key, std::string_view channel);
    void forget_least_recent();
    // In-order bytes of a TCP stream (or a datagram, `stream` false).
    void take(Flow& flow, std::span<const std::uint8_t> bytes, Nanos time, std::uint32_t not_captured,
              bool stream);
    // Hands on what `flow.pending` holds: frames and what they cannot be, up to the start
    // of a frame not yet complete; everything when `flush`.
    void hand_on(Flow& flow, bool flush, std::uint32_t not_captured);
    // The segments held early that are now in order.
    void take_early(Flow& flow);
    // Gives up waiting for the bytes before the first early segment: what is pending goes,
    // then the early segments, the missing bytes counted.
    void skip_gap(Flow& flow);
    void flush(Flow& flow);
    void add_early(Flow& flow, std::uint64_t offset, std::span<const std::uint8_t> bytes,
                   Nanos time, std::uint32_t length, bool fin);
    void forget_early(Flow& flow);
    void skip_packets(const Flow& flow, std::size_t from_mark, std::size_t to_mark);

    Output& out_;
    std::vector<std::uint16_t> rtu_ports_;
    std::unordered_map<FlowKey, Flow, FlowKeyHash> flows_;
    std::list<FlowKey> recent_;  // most recently active first
    std::size_t held_bytes_ = 0;  // early bytes of all streams
    // Bounds hit, for the remarks.
    std::uint64_t flows_forgotten_ = 0;
    std::uint64_t held_bound_hits_ = 0;
    std::uint64_t gaps_skipped_ = 0;
    std::uint64_t bytes_missed_ = 0;
};

}  // namespace rtuscope
