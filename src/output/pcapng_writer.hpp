// pcapng out (`--pcapng FILE`): the frames --pcap writes, as the same exported PDUs (link
// type 252, output/pcap_writer.hpp), with what a classic pcap cannot hold for Wireshark
// and for whoever the file is handed to: the direction as the packet's flags, the line
// the frames were heard on, and rtuscope's notes, pairing and values as a comment on
// each frame. The blocks and options: docs/formats.md ("pcapng output").
//
//   tshark -r out.pcapng -V                                    flags and comments shown
//   tshark -r out.pcapng -Y 'frame.comment contains "no_answer"'
//
// Written by hand (libpcap writes no pcapng), little-endian, after the pcapng
// specification (draft-ietf-opsawg-pcapng): every block and option padded to 32 bits,
// every block's length at its start and its end.
#pragma once

#include <cstdint>
#include <cstdio>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "pipeline.hpp"
#include "util/result.hpp"

namespace rtuscope {

// A RecordSink writing a pcapng file: a section header block naming the application, an
// interface description block for each line the frames came on (the input, or each
// channel of a two-port tap) before its first frame, and an enhanced packet block for
// each frame PcapSink writes, with the same payload and time (nanoseconds).
// Errors as PcapSink: the first one kept, status() reports it.
class PcapngSink : public RecordSink {
  public:
    ~PcapngSink() override;
    PcapngSink(const PcapngSink&) = delete;
    PcapngSink& operator=(const PcapngSink&) = delete;

    void begin(const SessionInfo& session) override;
    void record(const Record& record) override;
    void end(const Totals& totals, const std::vector<std::string>& remarks) override;
    void flush() override;

    // The first error met while writing or closing, or ok.
    [[nodiscard]] Status status() const;
    [[nodiscard]] std::uint64_t packets() const { return packets_; }

  private:
    friend Result<std::unique_ptr<PcapngSink>> make_pcapng_sink(const std::string& path,
                                                               std::string_view application);
    PcapngSink(std::FILE* file, std::string path);
    // The interface of the frame's channel, described in the file on its first frame.
    std::uint32_t interface_for(const std::string& channel);
    void write_block(std::uint32_t type, const std::vector<std::uint8_t>& body);
    void write(const void* data, std::size_t size);
    void fail(const char* what, int err);

    std::FILE* file_ = nullptr;
    std::string path_;
    std::unique_ptr<char[]> write_buffer_;  // the file's stdio buffer, kept past fclose
    SessionInfo session_;
    std::map<std::string, std::uint32_t> interfaces_;  // channel, interface id
    // One block, built anew for each frame in the same room.
    std::vector<std::uint8_t> body_;
    std::vector<std::uint8_t> block_;
    std::vector<std::uint8_t> payload_;
    std::string comment_;
    std::uint64_t packets_ = 0;
    std::optional<Error> error_;
};

// Creates (truncates) `path` and writes the section header block, naming `application`
// ("rtuscope 1.2.0") as the writer; the error names the file.
Result<std::unique_ptr<PcapngSink>> make_pcapng_sink(const std::string& path,
                                                    std::string_view application);

// The comment rtuscope writes on a frame, its lines apart by "\n": "rtuscope #13 response:
// 4.53 ms after #12" (its record number as the text output shows it, its kind and pairing;
// a request: "answered by #13"), a line "! txn.no_answer: ..." per note (id and text), and
// a line per value as the text output writes them under the frame ("voltage = 220.5 V (raw
// 0x089D)"). It begins with kOwnCommentPrefix (input/pcap.hpp).
void append_frame_comment(std::string& out, const Record& record);

}  // namespace rtuscope
