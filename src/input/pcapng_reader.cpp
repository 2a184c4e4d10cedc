// The pcapng block reader. Layouts: draft-ietf-opsawg-pcapng (the pcapng specification),
// sections 4.1-4.4 and 4.6 (obsolete packet block: appendix A).
//
//   block:  type (4)  total length (4)  body  total length (4), every length a multiple of 4
//   SHB 0x0A0D0D0A:  byte-order magic 0x1A2B3C4D (4)  major 1 (2)  minor (2)  section
//                    length (8)  options
//   IDB 1:           link type (2)  reserved (2)  snap length (4)  options
//   EPB 6:           interface (4)  time high (4)  time low (4)  captured (4)  length (4)
//                    data, padded to 4  options
//   SPB 3:           length (4)  data, padded to 4  (interface 0, no time)
//   PB 2:            interface (2)  drops (2)  time high (4)  time low (4)  captured (4)
//                    length (4)  data, padded to 4  options
//   option:          code (2)  length (2)  value, padded to 4; code 0 ends them
//   kept:  shb_userappl 4 (SHB), if_description 3 and if_tsresol 9 and if_tsoffset 14
//          (IDB), opt_comment 1 and epb_flags 2 (EPB, PB; bits 0-1: 1 inbound, 2 outbound)
#include "input/pcapng_reader.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "util/io_block.hpp"

namespace rtuscope::pcap {
namespace {

constexpr std::uint32_t kSectionHeader = 0x0A0D0D0A;
constexpr std::uint32_t kInterfaceDescription = 1;
constexpr std::uint32_t kObsoletePacket = 2;
constexpr std::uint32_t kSimplePacket = 3;
constexpr std::uint32_t kEnhancedPacket = 6;
constexpr std::uint32_t kByteOrderMagic = 0x1A2B3C4D;
constexpr std::uint16_t kOptionEnd = 0;
constexpr std::uint16_t kOptionComment = 1;
constexpr std::uint16_t kOptionFlags = 2;        // epb_flags, pack_flags
constexpr std::uint16_t kOptionDescription = 3;  // if_description
constexpr std::uint16_t kOptionUserAppl = 4;     // shb_userappl
constexpr std::uint16_t kOptionTsResolution = 9;
constexpr std::uint16_t kOptionTsOffset = 14;
constexpr std::size_t kHeaderBytes = 8;    // type and total length
constexpr std::size_t kMinBlockBytes = 12;  // header and trailer

// 10^n for n up to 19, the powers of ten that fit in 64 bits.
constexpr unsigned kMaxPowerOfTen = 19;
constexpr std::uint64_t power_of_ten(unsigned n) {
    std::uint64_t p = 1;
    for (unsigned i = 0; i < n; ++i) p *= 10;
    return p;
}

// `units` of 10^-n (or 2^-n) seconds in nanoseconds, offset by whole seconds; false when
// it does not fit.
bool to_nanos(std::uint64_t units, std::uint8_t n, bool binary, std::int64_t offset_seconds,
              Nanos& out) {
    constexpr auto kBillion = static_cast<std::uint64_t>(kNanosPerSecond);
    std::uint64_t ns = 0;
    if (binary) {
        // Units finer than 2^-34 s are counted in 2^-34 s (58 ps): nothing a nanosecond
        // shows is lost, and the fraction times 10^9 fits in 64 bits.
        constexpr unsigned kFinest = 34;
        unsigned shift = n;
        if (shift > kFinest) {
            units = shift - kFinest >= 64 ? 0 : units >> (shift - kFinest);
            shift = kFinest;
        }
        const std::uint64_t whole = units >> shift;
        const std::uint64_t fraction = units & ((std::uint64_t{1} << shift) - 1);
        if (__builtin_mul_overflow(whole, kBillion, &ns)) return false;
        ns += (fraction * kBillion) >> shift;
    } else if (n <= 9) {
        if (__builtin_mul_overflow(units, power_of_ten(9U - n), &ns)) return false;
    } else if (n - 9U <= kMaxPowerOfTen) {
        ns = units / power_of_ten(n - 9U);
    }
    if (ns > static_cast<std::uint64_t>(kMaxTime)) return false;
    Nanos offset = 0;
    if (__builtin_mul_overflow(offset_seconds, kNanosPerSecond, &offset)) return false;
    Nanos time = 0;
    if (__builtin_add_overflow(static_cast<Nanos>(ns), offset, &time)) return false;
    if (time > kMaxTime || time < -kMaxTime) return false;
    out = time;
    return true;
}

}  // namespace

bool written_by_rtuscope(std::string_view head) {
    const auto byte = [&](std::size_t i) { return static_cast<std::uint8_t>(head[i]); };
    if (head.size() < 28 || head.substr(0, 4) != std::string_view("\x0A\x0D\x0D\x0A", 4)) {
        return false;
    }
    const bool big = head.substr(8, 4) == std::string_view("\x1A\x2B\x3C\x4D", 4);
    if (!big && head.substr(8, 4) != std::string_view("\x4D\x3C\x2B\x1A", 4)) return false;
    const auto u16 = [&](std::size_t at) {
        return static_cast<std::uint16_t>(big ? (byte(at) << 8) | byte(at + 1)
                                              : (byte(at + 1) << 8) | byte(at));
    };
    const auto u32 = [&](std::size_t at) {
        const std::uint32_t a = u16(at);
        const std::uint32_t b = u16(at + 2);
        return big ? (a << 16) | b : (b << 16) | a;
    };
    const std::size_t length = u32(4);
    if (length < 28 || length > head.size()) return false;
    const std::size_t end = length - 4;
    for (std::size_t at = 24; at + 4 <= end;) {
        const std::uint16_t code = u16(at);
        const std::size_t size = u16(at + 2);
        at += 4;
        if (code == kOptionEnd || size > end - at) return false;
        if (code == kOptionUserAppl) return head.substr(at, size).starts_with("rtuscope ");
        at += (size + 3) & ~std::size_t{3};
    }
    return false;
}

PcapngReader::PcapngReader(std::FILE* file)
    : file_(file), stdio_buffer_(give_stdio_buffer(file)) {}

PcapngReader::~PcapngReader() {
    std::fclose(file_);
}

std::uint16_t PcapngReader::u16(std::size_t at) const {
    const std::uint8_t a = block_[at];
    const std::uint8_t b = block_[at + 1];
    return static_cast<std::uint16_t>(big_endian_ ? (a << 8) | b : (b << 8) | a);
}

std::uint32_t PcapngReader::u32(std::size_t at) const {
    const std::uint32_t a = u16(at);
    const std::uint32_t b = u16(at + 2);
    return big_endian_ ? (a << 16) | b : (b << 16) | a;
}

Error PcapngReader::error(const std::string& what) const {
    return Error{fmt::format("pcapng block at byte {}: {}", block_offset_, what)};
}

std::vector<int> PcapngReader::link_types() const {
    std::vector<int> out;
    for (const Interface& i : interfaces_) out.push_back(i.link_type);
    return out;
}

Result<bool> PcapngReader::read_block() {
    block_offset_ = next_offset_;
    block_.resize(kHeaderBytes + 4);
    const std::size_t got = std::fread(block_.data(), 1, kHeaderBytes, file_);
    if (got == 0 && std::feof(file_) != 0) return false;
    if (got < kHeaderBytes) {
        if (std::ferror(file_) != 0) return error("cannot read the file");
        cut_off_ = true;
        return false;
    }
    block_type_ = u32(0);
    std::size_t head = kHeaderBytes;
    if (block_type_ == kSectionHeader) {
        // The byte-order magic after the length says how to read the length.
        if (std::fread(block_.data() + kHeaderBytes, 1, 4, file_) < 4) {
            if (std::ferror(file_) != 0) return error("cannot read the file");
            cut_off_ = true;
            return false;
        }
        big_endian_ = false;
        if (u32(kHeaderBytes) != kByteOrderMagic) {
            big_endian_ = true;
            if (u32(kHeaderBytes) != kByteOrderMagic) {
                return error("a section header without the byte-order magic 1A2B3C4D");
            }
        }
        head += 4;
    } else if (!in_section_) {
        return error("the file does not start with a section header block");
    }
    const std::uint32_t length = u32(4);
    if (length < kMinBlockBytes || length % 4 != 0 || length > kMaxBlockBytes ||
        length < head + 4) {
        return error(fmt::format("block length {} (a multiple of 4 from {} to {} bytes)", length,
                                 head + 4, kMaxBlockBytes));
    }
    block_.resize(length);
    const std::size_t rest = length - head;
    if (std::fread(block_.data() + head, 1, rest, file_) < rest) {
        if (std::ferror(file_) != 0) return error("cannot read the file");
        cut_off_ = true;
        return false;
    }
    if (u32(length - 4) != length) {
        return error(
            fmt::format("its lengths disagree ({} at its start, {} at its end)", length,
                        u32(length - 4)));
    }
    next_offset_ += length;
    return true;
}

Status PcapngReader::read_section_header() {
    // type, length, magic, major, minor, section length (8), options, trailer
    if (block_.size() < 28) return error("a section header shorter than 28 bytes");
    if (u16(12) != 1) return error(fmt::format("pcapng version {}.{} (1.x is read)", u16(12), u16(14)));
    in_section_ = true;
    interfaces_.clear();
    return ok_status();
}

Status PcapngReader::read_interface() {
    // type, length, link type, reserved, snap length, options, trailer
    if (block_.size() < 20) return error("an interface description shorter than 20 bytes");
    if (interfaces_.size() >= kMaxInterfaces) {
        return error(fmt::format("more than {} interfaces in one section", kMaxInterfaces));
    }
    Interface interface;
    interface.link_type = u16(8);
    interface.snap_length = u32(12);
    const std::size_t end = block_.size() - 4;
    for (std::size_t at = 16; at + 4 <= end;) {
        const std::uint16_t code = u16(at);
        const std::size_t length = u16(at + 2);
        at += 4;
        if (code == kOptionEnd) break;
        if (length > end - at) return error("an interface option runs past its block");
        if (code == kOptionTsResolution && length >= 1) {
            interface.binary = (block_[at] & 0x80U) != 0;
            interface.resolution = static_cast<std::uint8_t>(block_[at] & 0x7FU);
        } else if (code == kOptionDescription) {
            interface.description.assign(reinterpret_cast<const char*>(&block_[at]), length);
        } else if (code == kOptionTsOffset && length == 8) {
            const std::uint64_t high = u32(at);
            const std::uint64_t low = u32(at + 4);
            const std::uint64_t value = big_endian_ ? (high << 32) | low : (low << 32) | high;
            interface.offset_seconds = static_cast<std::int64_t>(value);
        }
        at += (length + 3) & ~std::size_t{3};
    }
    interfaces_.push_back(interface);
    return ok_status();
}

std::optional<LineSettings> PcapngReader::described_line() const {
    std::optional<LineSettings> line;
    for (const Interface& interface : interfaces_) {
        if (interface.description.empty()) continue;
        auto described = parse_line_settings(interface.description);
        if (!described) return {};  // a description of something else
        if (line && (line->baud != described->baud || line->format() != described->format())) {
            return {};
        }
        line = *described;
    }
    return line;
}

Status PcapngReader::read_packet_options(std::size_t at, Packet& out) const {
    const std::size_t end = block_.size() - 4;
    while (at + 4 <= end) {
        const std::uint16_t code = u16(at);
        const std::size_t length = u16(at + 2);
        at += 4;
        if (code == kOptionEnd) break;
        if (length > end - at) {
            return error(fmt::format("packet {}: an option runs past its block", packets_));
        }
        if (code == kOptionFlags && length == 4) {
            switch (u32(at) & 3U) {
                case 1:
                    out.direction = PacketDirection::inbound;
                    break;
                case 2:
                    out.direction = PacketDirection::outbound;
                    break;
                default:
                    break;
            }
        } else if (code == kOptionComment) {
            out.comments.emplace_back(reinterpret_cast<const char*>(&block_[at]), length);
        }
        at += (length + 3) & ~std::size_t{3};
    }
    return ok_status();
}

Result<bool> PcapngReader::read_packet(Packet& out) {
    const std::size_t end = block_.size() - 4;  // before the trailer
    std::uint32_t interface = 0;
    std::size_t data_at = 0;
    std::uint32_t captured = 0;
    std::uint32_t length = 0;
    bool timed = true;
    std::uint64_t units = 0;
    switch (block_type_) {
        case kEnhancedPacket:
        case kObsoletePacket: {
            if (end < 28) return error("a packet block shorter than its header");
            const bool obsolete = block_type_ == kObsoletePacket;
            interface = obsolete ? u16(8) : u32(8);
            units = (std::uint64_t{u32(12)} << 32) | u32(16);
            captured = u32(20);
            length = u32(24);
            data_at = 28;
            if (captured > end - data_at) {
                return error(fmt::format("packet {}: {} bytes captured run past its block",
                                         packets_ + 1, captured));
            }
            break;
        }
        case kSimplePacket: {
            if (end < 12) return error("a simple packet block shorter than its header");
            length = u32(8);
            data_at = 12;
            timed = false;
            // The data is the packet, padded, cut at the interface's snap length.
            captured = static_cast<std::uint32_t>(std::min<std::size_t>(length, end - data_at));
            if (!interfaces_.empty() && interfaces_[0].snap_length != 0) {
                captured = std::min(captured, interfaces_[0].snap_length);
            }
            break;
        }
        default:
            return false;  // not a packet: skipped
    }
    ++packets_;
    if (interface >= interfaces_.size()) {
        return error(fmt::format("packet {}: interface {} was not described before it",
                                 packets_, interface));
    }
    const Interface& described = interfaces_[interface];
    out.link_type = described.link_type;
    out.data = std::span<const std::uint8_t>(block_).subspan(data_at, captured);
    out.length = std::max(length, captured);
    out.direction = PacketDirection::unknown;
    out.comments.clear();
    if (block_type_ != kSimplePacket) {
        const std::size_t options_at = data_at + ((std::size_t{captured} + 3) & ~std::size_t{3});
        if (Status read = read_packet_options(options_at, out); !read) return read.error();
    }
    out.time = kNoTime;
    if (timed && !to_nanos(units, described.resolution, described.binary,
                           described.offset_seconds, out.time)) {
        return error(fmt::format("packet {}: timestamp out of range", packets_));
    }
    return true;
}

Status PcapngReader::open() {
    Result<bool> packet = next(first_);
    if (!packet) return packet.error();
    has_first_ = *packet;
    return ok_status();
}

Result<bool> PcapngReader::next(Packet& out) {
    if (has_first_) {
        has_first_ = false;
        out = first_;
        return true;
    }
    for (;;) {
        Result<bool> block = read_block();
        if (!block || !*block) return block;
        Status read = ok_status();
        switch (block_type_) {
            case kSectionHeader:
                read = read_section_header();
                break;
            case kInterfaceDescription:
                read = read_interface();
                break;
            default: {
                Result<bool> packet = read_packet(out);
                if (!packet || *packet) return packet;
                break;
            }
        }
        if (!read) return read.error();
    }
}

}  // namespace rtuscope::pcap
