// Stage 1, sources: everything that delivers bytes (capture files, raw dumps, hex logs,
// pcap files, a tty) delivers Chunks through the ChunkSource interface.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "framing/line_settings.hpp"
#include "framing/transport.hpp"
#include "util/result.hpp"
#include "util/time.hpp"

namespace rtuscope {

// Bytes that arrived together: what one read() on a tty returns, one line of a capture
// file, one byte of a logic-analyser export, one line of a hex log.
struct Chunk {
    // When the LAST byte of the chunk was received; its first byte's start instead when
    // the source says so (SourceInfo::chunk_time_is_start).
    Nanos time = kNoTime;
    std::string channel;  // "@NAME" of a two-port tap; empty when there is one line
    std::vector<std::uint8_t> bytes;
    int source_line = 0;  // line in the input file, 0 when the source has no lines
    // Offsets of bytes the UART received with a parity or framing error (a live tty with
    // PARMRK); such a byte is kept as it came, and the frame it lands in says so.
    std::vector<std::uint32_t> char_errors;
    // The bytes are exactly one frame, to be taken as it is (a pcap packet, a hex log's
    // line that holds one frame by length and CRC); otherwise they are bytes of the
    // stream, for the framer to cut (a frame over several chunks, several in one).
    bool whole_frame = false;
    // Whole frames: how long the frame took on the line, first byte's start to last
    // byte's end, when the source knows it (a pcap rtuscope wrote); else the character
    // time of the line settings gives it.
    Nanos duration = kNoTime;
    // Whole frames and packets: the time is an estimate (the frame was found inside a
    // chunk a USB adapter delivered with others; a TCP stream's bytes that came after
    // frames in an earlier segment), so the silence before it is not known.
    bool time_estimated = false;
    // The bytes are one packet of a capture (a pcap), to be framed on their own: no frame
    // runs into it or out of it. A serial sniffer cuts its packets at silences, and TCP
    // and UDP carry a frame or more a packet, so a packet's start is a frame boundary
    // whatever the silence before it, and what came before it is decided first.
    bool packet = false;
    // Packets: how many of the packet's bytes the capture did not keep (its snap length
    // cut it). Bytes at its end that form no whole frame were cut by the capture, not on
    // the line.
    std::uint32_t bytes_not_captured = 0;
    // An empty chunk after the port was gone (an adapter unplugged, then back; sniff
    // --reopen): nothing was heard from this time until the chunk's time.
    Nanos gap_since = kNoTime;
    // Whole frames: Modbus/TCP (bytes: the unit id and the PDU) or RTU.
    Transport transport = Transport::rtu;
    Mbap mbap{};  // Modbus/TCP only
    // Whole frames of a pcapng file: its comments on the packet (opt_comment) that rtuscope
    // did not write itself (output/pcapng_writer.hpp), e.g. added in Wireshark.
    std::vector<std::string> comments{};
};

// What a source knows about itself once its header (if any) has been read.
struct SourceInfo {
    std::string name;                     // file name for messages, "-" for stdin
    std::string format;                   // "capture", "raw", "hex", "pcap", "live"
    std::optional<LineSettings> line;     // from the capture header, if it has one
    bool timed = false;                   // chunks carry times
    TimeBase time_base = TimeBase::none;  // what those times are (util/time.hpp)
    // A chunk's time is its first byte's start (pcap, hex logs), not its last byte's end.
    bool chunk_time_is_start = false;
    // Hex logs: a chunk is a line someone wrote, a frame or a piece of one, so a line's
    // start is where bytes that form no frame are cut.
    bool chunk_is_line = false;
    // What a capture's header says beyond the line (docs/formats.md), so that a capture
    // decodes the same on any machine: the program that wrote it, its device map (slave
    // address, profile name) and the TOML text of the profiles that are not bundled.
    std::string written_by;
    std::vector<std::pair<std::uint8_t, std::string>> devices;
    std::vector<std::pair<std::string, std::string>> embedded_profiles;  // name, TOML text
};

class ChunkSource {
  public:
    virtual ~ChunkSource() = default;
    [[nodiscard]] virtual const SourceInfo& info() const = 0;
    // Fills `out` and returns true, returns false at the end of input, or an Error
    // (file:line:col) for input that cannot be read on.
    virtual Result<bool> next(Chunk& out) = 0;
    // Remarks worth telling the user once the input is read, e.g. the lines a hex
    // reader skipped. Empty for most sources.
    [[nodiscard]] virtual std::vector<std::string> remarks() const { return {}; }
    // Whether the input ends where a live run was stopped (a capture's `# stopped` line):
    // a frame on the line then was cut by the stop, not by the bus.
    [[nodiscard]] virtual bool ended_by_stop() const { return false; }
};

}  // namespace rtuscope
