// Internal to the pcap reader: the packets of a pcap or pcapng file, wherever they are
// read (libpcap, or rtuscope's own pcapng reader where libpcap refuses a file), and the
// chunks they become (PacketChunker).
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "input/chunk.hpp"
#include "input/ip_flows.hpp"
#include "input/pcap.hpp"
#include "util/result.hpp"
#include "util/time.hpp"

namespace rtuscope::pcap {

using Bytes = std::span<const std::uint8_t>;

// pcapng's epb_flags direction. rtuscope writes an exported PDU's as the ports say it:
// outbound to a slave (a request), inbound from one (an answer).
enum class PacketDirection : std::uint8_t { unknown, inbound, outbound };

struct Packet {
    // The interface's link type, as libpcap's pcap_datalink gives it (DLT_) or as the
    // file holds it (LINKTYPE_): the two differ only for raw IP, and both are read.
    int link_type = 0;
    Nanos time = kNoTime;  // the packet's timestamp; none for a pcapng simple packet block
    Bytes data;            // the bytes captured, valid until the next packet is read
    // Its length on the wire: more than data.size() when the capture's snap length cut it.
    std::uint32_t length = 0;
    // pcapng only (rtuscope's own reader): the direction its flags give (epb_flags), and
    // its comments (opt_comment), valid until the next packet is read.
    PacketDirection direction = PacketDirection::unknown;
    std::vector<std::string_view> comments;
};

// Where packets come from.
class PacketReader {
  public:
    virtual ~PacketReader() = default;
    // The next packet; false at the end of the file, also when the file ends inside a
    // packet (cut_off() then says so). An Error (without the file name) for a file broken
    // before its end.
    virtual Result<bool> next(Packet& out) = 0;
    // Whether the file ended inside a packet (a capture killed or still being written).
    [[nodiscard]] virtual bool cut_off() const = 0;
    // The line settings the interfaces described so far give in their descriptions
    // ("9600 8N1", as rtuscope writes them), when they give one and agree; libpcap tells
    // none.
    [[nodiscard]] virtual std::optional<LineSettings> described_line() const { return {}; }
};

// Whether packets of this link type can carry Modbus (the table in docs/formats.md).
bool supported_link_type(int link_type);

// Turns packets into chunks: a packet that is exactly one frame by length and CRC (and
// every exported PDU, which a dissector framed) becomes a whole-frame chunk, any other a
// packet chunk for the framer to cut, a Modbus/TCP ADU a whole-frame chunk of
// Transport::tcp; TCP streams are reassembled first, and payloads that are neither Modbus
// RTU nor Modbus/TCP are skipped and counted (ip_flows.hpp). A packet gives none, one or
// several chunks, taken with pop().
class PacketChunker final : private IpFlows::Output {
  public:
    explicit PacketChunker(const PcapOptions& options);
    PacketChunker(const PacketChunker&) = delete;
    PacketChunker& operator=(const PacketChunker&) = delete;
    ~PacketChunker() override = default;

    // Packet `number` (1-based, counting every packet of the file). An Error (naming the
    // packet) for a packet broken where it should not be.
    Status add(const Packet& packet, std::uint64_t number);
    // The end of the file: what TCP streams still hold comes out.
    void finish();
    // The next chunk, swapped into `out` (their buffers change hands); false when none
    // waits.
    bool pop(Chunk& out);
    // What was skipped or cut, and why; `cut_off`: the file ended inside the next packet.
    [[nodiscard]] std::vector<std::string> remarks(bool cut_off) const;

  private:
    void rtu(Bytes bytes, Nanos time, bool time_estimated, std::string_view channel,
             std::uint32_t not_captured) override;
    void modbus_tcp(Bytes adu, Nanos time, bool time_estimated, std::string_view channel,
                    const FlowKey& flow) override;
    void skipped(IpFlows::Skip why, const FlowKey& flow, std::uint64_t packets) override;
    // One chunk of `bytes`: a whole frame when they are one (or `framed`: an exported PDU)
    // and complete, else a packet.
    void emit(Bytes bytes, Nanos time, bool time_estimated, std::string_view channel,
              std::uint32_t not_captured, bool framed, Nanos duration);
    // The next chunk's slot, filled by the caller.
    Chunk& next_chunk(Nanos& time, bool& time_estimated, std::string_view channel);
    // The comments of the packet being added onto its frame's chunk, but for rtuscope's
    // own (its decoding of the frame, which decoding it again gives anew).
    void keep_comments(Chunk& out) const;
    void skip(const std::string& why);

    IpFlows flows_;
    // Chunks waiting for pop(), from queue_[head_] to queue_[size_ - 1]; the slots keep
    // their buffers.
    std::vector<Chunk> queue_;
    std::size_t head_ = 0;
    std::size_t size_ = 0;
    Nanos packet_time_ = kNoTime;    // the packet being added
    Nanos last_emitted_ = kNoTime;   // the time of the last chunk out
    std::uint64_t packets_ = 0;
    // Reasons are counted apart up to a bound: each dissector name is one, and a crafted
    // file could hold millions of them.
    static constexpr std::size_t kMaxSkipReasons = 32;
    std::map<std::string, std::uint64_t> skipped_;
    std::uint64_t skipped_otherwise_ = 0;  // for reasons beyond kMaxSkipReasons
    std::uint64_t retransmissions_ = 0;
    std::uint64_t not_modbus_ = 0;
    // The packets not Modbus by their flow's lower port (where a server listens), for the
    // remark; ports beyond kMaxPortsCounted are counted in not_modbus_ only.
    static constexpr std::size_t kMaxPortsCounted = 64;
    std::map<std::uint16_t, std::uint64_t> not_modbus_ports_;
    // Packets of interfaces whose link type carries no RTU (pcapng files with several).
    static constexpr std::size_t kMaxLinkTypesCounted = 64;
    std::map<int, std::uint64_t> unsupported_link_types_;
    std::uint64_t unsupported_otherwise_ = 0;
    std::uint64_t cut_by_snaplen_ = 0;  // packets the capture's snap length cut
    // Exported PDUs whose direction flags say otherwise than their ports (the flags are
    // taken).
    std::uint64_t direction_disagreements_ = 0;
    // The comments of the packet being added, for the chunk of the frame it is.
    std::span<const std::string_view> packet_comments_;
};

}  // namespace rtuscope::pcap
