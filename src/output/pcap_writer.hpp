// pcap out (`--pcap FILE`): every frame rtuscope decided on, written as a Wireshark
// "exported PDU" packet (link type 252) that names the Modbus RTU dissector and carries the
// direction as TCP ports, so that Wireshark shows the frames as Modbus RTU queries and
// responses.
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
#include <vector>

#include "input/pcap.hpp"
#include "pipeline.hpp"
#include "util/result.hpp"

namespace rtuscope {

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

// What the pcap and pcapng files hold, alike:
// Whether the record is written: frames only, invalid ones included; not noise, nor the
// part of a frame a stop or a capture's snap length cut off.
bool is_written(const Record& record);
// Which way the frame went: its kind, else its reading, else its tap channel ("master"
// is the master's side). The port tags and pcapng's direction flags say it.
enum class FrameDirection : std::uint8_t { to_slave, from_slave, unclear };
FrameDirection direction_of(const Record& record);
// The packet's time in ns: the frame's start, as Wireshark users compare frame starts (the
// reader knows and puts the frame back where it was). Untimed frames get their record
// number in microseconds, so that Wireshark keeps their order and shows a plausible (fake)
// spacing.
Nanos packet_time(const Record& record);

}  // namespace rtuscope
