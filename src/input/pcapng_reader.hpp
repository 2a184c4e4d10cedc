// Internal to the pcap reader: rtuscope's own pcapng reader, for the files libpcap
// refuses. libpcap reads a pcapng file only when all its interfaces share one link type
// and one snap length; mergecap writes an Ethernet capture and a serial one into one file
// with two. This reader takes section header, interface description, enhanced, simple
// and (obsolete) packet blocks, and skips every other block; either byte order, any
// number of sections, the interface's time unit (if_tsresol) and offset (if_tsoffset).
// Every length is checked against the block it is in; it holds one block at a time (at
// most kMaxBlockBytes) and at most kMaxInterfaces interfaces a section.
// The options kept: an interface's time unit and offset and its description
// (if_description, which rtuscope writes as the line settings: described_line()); a packet
// block's direction flags and comments (Packet::direction, Packet::comments).
#pragma once

#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "input/pcap_packets.hpp"
#include "util/result.hpp"

namespace rtuscope::pcap {

inline constexpr std::size_t kMaxBlockBytes = std::size_t{16} << 20;  // as libpcap's bound
inline constexpr std::size_t kMaxInterfaces = std::size_t{1} << 16;

// Whether `head` starts with a pcapng section header block whose writing application
// (shb_userappl) is rtuscope: such a file is read by this reader, which gives its packets'
// direction flags and comments and its interfaces' line settings, where libpcap gives
// none.
bool written_by_rtuscope(std::string_view head);

class PcapngReader final : public PacketReader {
  public:
    // Takes `file` (closed with the reader), which starts at a pcapng section header.
    explicit PcapngReader(std::FILE* file);
    ~PcapngReader() override;
    PcapngReader(const PcapngReader&) = delete;
    PcapngReader& operator=(const PcapngReader&) = delete;

    // Reads up to the first packet, so that the interfaces described before it are
    // known (link_types()); an Error for a file that is no pcapng or is broken there.
    Status open();
    Result<bool> next(Packet& out) override;
    [[nodiscard]] bool cut_off() const override { return cut_off_; }
    // The link types of the interfaces described so far.
    [[nodiscard]] std::vector<int> link_types() const;
    [[nodiscard]] std::optional<LineSettings> described_line() const override;

  private:
    struct Interface {
        int link_type = 0;
        std::uint32_t snap_length = 0;
        // if_tsresol: 10^-n seconds (decimal) or 2^-n (binary); microseconds by default.
        std::uint8_t resolution = 6;
        bool binary = false;
        std::int64_t offset_seconds = 0;  // if_tsoffset
        std::string description;          // if_description
    };
    // The next block into block_; false at the end of the file (cut_off_ when it ends
    // inside one).
    Result<bool> read_block();
    Status read_section_header();
    Status read_interface();
    // The packet in block_, if it is a packet block: true when `out` holds one.
    Result<bool> read_packet(Packet& out);
    // The options of a packet block from `at`: its direction flags and comments.
    Status read_packet_options(std::size_t at, Packet& out) const;
    [[nodiscard]] std::uint16_t u16(std::size_t at) const;
    [[nodiscard]] std::uint32_t u32(std::size_t at) const;
    Error error(const std::string& what) const;

    std::FILE* file_;
    std::unique_ptr<char[]> stdio_buffer_;
    std::vector<std::uint8_t> block_;  // the current block, its header and trailer included
    std::uint32_t block_type_ = 0;
    std::uint64_t block_offset_ = 0;  // in the file, for messages
    std::uint64_t next_offset_ = 0;
    bool big_endian_ = false;
    bool in_section_ = false;
    std::vector<Interface> interfaces_;
    std::uint64_t packets_ = 0;
    bool cut_off_ = false;
    bool has_first_ = false;  // open() read the first packet: next() gives it first
    Packet first_;
};

}  // namespace rtuscope::pcap
