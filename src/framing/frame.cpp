#include "framing/frame.hpp"

namespace rtuscope {

std::span<const std::uint8_t> pdu_of(std::span<const std::uint8_t> bytes, Transport transport) {
    if (transport == Transport::tcp) {
        if (bytes.size() < 2) return {};  // unit id, function at least
        return bytes.subspan(1);
    }
    if (bytes.size() < 4) return {};  // address, function, CRC at least
    return bytes.subspan(1, bytes.size() - 3);
}

const char* to_string(Transport transport) {
    return transport == Transport::tcp ? "tcp" : "rtu";
}

const char* to_string(RecordClass cls) {
    switch (cls) {
        case RecordClass::frame:
            return "frame";
        case RecordClass::invalid:
            return "invalid";
        case RecordClass::noise:
            return "noise";
    }
    return "";
}

const char* to_string(Delimiter delimiter) {
    switch (delimiter) {
        case Delimiter::gap:
            return "gap";
        case Delimiter::length_crc:
            return "length+crc";
        case Delimiter::crc_search:
            return "crc-search";
        case Delimiter::end_of_input:
            return "end of input";
        case Delimiter::line:
            return "line";
    }
    return "";
}

bool is_whole_frame(std::span<const std::uint8_t> bytes, const ProtocolRules& rules) {
    if (bytes.size() < kMinAdu || bytes.size() > kMaxAdu) return false;
    if (check_crc(bytes).status == CrcStatus::bad) return false;
    const FrameLengths lengths = rules.frame_lengths(bytes);
    for (const Role role : {Role::request, Role::response}) {
        const FrameLength& length = lengths.of(role);
        if (length.kind == FrameLength::Kind::search) return true;
        if (length.kind == FrameLength::Kind::fixed && length.bytes == bytes.size()) return true;
    }
    return false;
}

}  // namespace rtuscope
