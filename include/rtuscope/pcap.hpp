// pcap in and out. Out (`--pcap FILE`): every frame rtuscope decided on, written as a
// Wireshark "exported PDU" packet (link type 252) that names the Modbus RTU dissector and
// carries the direction as TCP ports, so that Wireshark shows the frames as Modbus RTU
// queries and responses. In: pcap and pcapng files (libpcap) whose packets hold Modbus
// RTU frames: exported PDUs (252), RTAC serial (250), DLT_USER0-15 (147-162), and Modbus
// RTU over TCP or UDP in Ethernet, Linux cooked or raw IP captures.
//
// Reading the written file in tshark with query/response from the ports:
//   tshark -r out.pcap -o mbrtu.tcp.port:502 -o mbrtu.crc_verification:TRUE
// The dissector-name tag alone makes Wireshark decode the packets as Modbus RTU, but the
// mbrtu dissector only trusts the ports when 502 is in its "mbrtu.tcp.port" preference,
// which is empty by default; without it, it guesses query/response from the frame's
// shape (and cannot tell FC05/FC06 queries from their echoes). CRC checking is off by
// default in Wireshark; mbrtu.crc_verification:TRUE flags the bad-CRC frames.
#pragma once

#include <cstdint>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "rtuscope/chunk.hpp"
#include "rtuscope/pipeline.hpp"
#include "rtuscope/result.hpp"

namespace rtuscope {

// Link types (www.tcpdump.org/linktypes.html) the reader understands.
inline constexpr int kLinktypeUpperPdu = 252;    // LINKTYPE_WIRESHARK_UPPER_PDU
inline constexpr int kLinktypeRtacSerial = 250;  // LINKTYPE_RTAC_SERIAL
// The port standing for the slaves: requests go to it, answers come from it, in the
// file written and in the files read.
inline constexpr std::uint16_t kModbusPort = 502;
// The master's side of the written "connection".
inline constexpr std::uint16_t kMasterPort = 49152;

// A RecordSink writing a classic pcap file (nanosecond timestamps, link type 252). Every
// record that is a frame is written, invalid ones included: bad-CRC frames are what one
// wants to look at in Wireshark. Noise runs are not frames and are left out.
//
// Each packet's time is the START of the frame (record.frame.start), as rtuscope's text
// and CSV show it; the reader marks its chunks' times as starts (SourceInfo::
// chunk_time_is_start), so a written file read back gives the same frame times. Frames
// without timing (raw input) are stamped with their record number in microseconds from
// 0, which keeps their order.
//
// RecordSink's methods return nothing: the first write error is kept, later records are
// dropped, and status() reports it. end() flushes and closes the file; check status()
// after it.
class PcapSink : public RecordSink {
  public:
    ~PcapSink() override;
    PcapSink(const PcapSink&) = delete;
    PcapSink& operator=(const PcapSink&) = delete;

    void begin(const SessionInfo& session) override;
    void record(const Record& record) override;
    void end(const Totals& totals, const std::vector<std::string>& remarks) override;
    void flush() override;

    // The first error met while writing or closing, or ok.
    [[nodiscard]] Status status() const;
    [[nodiscard]] std::uint64_t packets() const { return packets_; }

  private:
    friend Result<std::unique_ptr<PcapSink>> make_pcap_sink(const std::string& path);
    PcapSink(std::FILE* file, std::string path);
    void write(const void* data, std::size_t size);
    void fail(const char* what, int err);

    std::FILE* file_ = nullptr;
    std::string path_;
    std::unique_ptr<char[]> write_buffer_;  // the file's stdio buffer, kept past fclose
    // One packet record, built anew for each frame in the same room.
    std::vector<std::uint8_t> header_;
    std::vector<std::uint8_t> packet_;
    std::uint64_t packets_ = 0;
    std::optional<Error> error_;
};

// Creates (truncates) `path` and writes the pcap file header; the error names the file.
Result<std::unique_ptr<PcapSink>> make_pcap_sink(const std::string& path);

// Appends the exported-PDU packet (tags and frame) written for one record to `out`.
void append_pcap_packet(std::vector<std::uint8_t>& out, const Record& record);

// A source over a pcap or pcapng file. Each packet holding a Modbus RTU frame becomes one
// Chunk (chunk_is_frame): its time is the packet's timestamp, the frame's start
// (chunk_time_is_start), its channel "master" when
// the packet went to port 502, "slave" when it came from port 502, empty otherwise.
// Packets that carry no frame (other protocols, empty TCP segments, exported PDUs for
// other dissectors) are skipped and counted in remarks(). A file cut short or corrupt
// gives its packets up to the bad one, then an error naming the packet.
Result<std::unique_ptr<ChunkSource>> open_pcap_source(const std::string& path);

// The same over a file in memory; `name` is used in messages.
Result<std::unique_ptr<ChunkSource>> pcap_source_from_memory(std::string content, std::string name);

// The same over `head` (bytes already read from the stream, e.g. by format detection)
// followed by the rest of `rest` (may be null). Owns `rest` when `close_rest`.
Result<std::unique_ptr<ChunkSource>> pcap_source_from_stream(std::string head, std::FILE* rest,
                                                             bool close_rest, std::string name);

// Whether `head` starts like a pcap or pcapng file (by its magic numbers).
bool looks_like_pcap(std::string_view head);

}  // namespace rtuscope
