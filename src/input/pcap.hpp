// pcap in: pcap and pcapng files whose packets hold Modbus RTU or Modbus/TCP: exported
// PDUs (link type 252, as `--pcap` writes them: output/pcap_writer.hpp), RTAC serial (250),
// DLT_USER0-15 (147-162), and Modbus RTU or Modbus/TCP over TCP or UDP in Ethernet, Linux
// cooked or raw IP captures.
// libpcap reads them, rtuscope's own pcapng reader the pcapng files libpcap refuses (with
// interfaces of several link types). The link types and ports below are shared with the
// writer.
#pragma once

#include <cstdint>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "input/chunk.hpp"
#include "util/result.hpp"

namespace rtuscope {

// Link types (www.tcpdump.org/linktypes.html) the reader understands.
inline constexpr int kLinktypeUpperPdu = 252;    // LINKTYPE_WIRESHARK_UPPER_PDU
inline constexpr int kLinktypeRtacSerial = 250;  // LINKTYPE_RTAC_SERIAL
// The port standing for the slaves: requests go to it, answers come from it, in the
// file written and in the files read.
inline constexpr std::uint16_t kModbusPort = 502;
// The master's side of the written "connection".
inline constexpr std::uint16_t kMasterPort = 49152;
// How the comment rtuscope writes on each frame of a pcapng file begins ("rtuscope #12
// request: answered by #13"); a reader leaves it out, as decoding gives it anew.
inline constexpr std::string_view kOwnCommentPrefix = "rtuscope #";

// A source over a pcap or pcapng file. A packet that is exactly one Modbus RTU frame by
// length and CRC (and every exported PDU) becomes a whole-frame Chunk
// (Chunk::whole_frame), any other a packet Chunk (Chunk::packet) the framer cuts into
// frames; a Modbus/TCP ADU is a whole-frame chunk of Transport::tcp (its unit id and PDU,
// its transaction id and connection in Chunk::mbap). TCP streams are reassembled first,
// so a frame or an ADU sent in two segments comes whole.
// A chunk's time is its packet's timestamp, its first byte's start (chunk_time_is_start);
// its channel "master" when the packet went to port 502, "slave" when it came from port
// 502, empty otherwise. Packets that carry no Modbus (other protocols, empty TCP
// segments, retransmissions, exported PDUs for other dissectors, interfaces of other link
// types) are skipped and counted in remarks(), and so are packets the capture's snap
// length cut. A file cut short or corrupt gives its packets up to the bad one, then an
// error naming the packet.
// What the user says of a capture's TCP and UDP traffic.
struct PcapOptions {
    // Ports whose payloads are Modbus RTU whatever they hold (a serial gateway's port):
    // framed as RTU even where no CRC checks, the side of the port being the slave's.
    // Other payloads are told apart by their content.
    std::vector<std::uint16_t> rtu_ports;
};

Result<std::unique_ptr<ChunkSource>> open_pcap_source(const std::string& path,
                                                      const PcapOptions& options = {});

// The same over a file in memory; `name` is used in messages.
Result<std::unique_ptr<ChunkSource>> pcap_source_from_memory(std::string content, std::string name,
                                                             const PcapOptions& options = {});

// The same through rtuscope's own pcapng reader alone, which is otherwise used only where
// libpcap refuses a file (tests, fuzzers).
Result<std::unique_ptr<ChunkSource>> pcapng_source_from_memory(std::string content,
                                                               std::string name);

// The same over `head` (bytes already read from the stream, e.g. by format detection)
// followed by the rest of `rest` (may be null). Owns `rest` when `close_rest`.
Result<std::unique_ptr<ChunkSource>> pcap_source_from_stream(std::string head, std::FILE* rest,
                                                             bool close_rest, std::string name,
                                                             const PcapOptions& options = {});

// Whether `head` starts like a pcap or pcapng file (by its magic numbers).
bool looks_like_pcap(std::string_view head);

}  // namespace rtuscope
