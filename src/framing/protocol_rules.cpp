// Frame lengths of the public function codes, from the request and response layouts of
// the Modbus Application Protocol Specification v1.1b3, section 6 (ADU = address + PDU +
// CRC, so every length below is the PDU length + 3).
#include "framing/protocol_rules.hpp"

namespace rtuscope {
namespace {

// `total` once it is known and within the serial-line ADU limit.
FrameLength checked(std::size_t total) {
    return total <= kMaxAdu ? FrameLength::fixed_at(total) : FrameLength::no_reading();
}

// A byte count at `offset` followed by that many bytes and the CRC.
FrameLength counted(std::span<const std::uint8_t> head, std::size_t offset) {
    if (head.size() <= offset) return FrameLength::need(offset + 1);
    return checked(offset + 1 + head[offset] + 2);
}

// 2B / 0E Read Device Identification answer: a list of objects, each id, length, value.
// addr fc mei code conformity more next count, then the objects.
FrameLength device_identification_answer(std::span<const std::uint8_t> head) {
    constexpr std::size_t kObjectsStart = 8;
    if (head.size() < kObjectsStart) return FrameLength::need(kObjectsStart);
    const unsigned objects = head[kObjectsStart - 1];
    std::size_t at = kObjectsStart;
    for (unsigned i = 0; i < objects; ++i) {
        if (head.size() < at + 2) return FrameLength::need(at + 2);
        at += 2U + head[at + 1];
        if (at + 2 > kMaxAdu) return FrameLength::no_reading();
    }
    return checked(at + 2);
}

FrameLength request_length(std::span<const std::uint8_t> head) {
    const std::uint8_t fc = head[1];
    switch (fc) {
        case 0x01:
        case 0x02:
        case 0x03:
        case 0x04:
        case 0x05:
        case 0x06:
            return FrameLength::fixed_at(8);
        case 0x07:
        case 0x0B:
        case 0x0C:
        case 0x11:
            return FrameLength::fixed_at(4);
        case 0x08:  // sub-function 0000 echoes any amount of data
            if (head.size() < 4) return FrameLength::need(4);
            return (head[2] == 0 && head[3] == 0) ? FrameLength::search_crc()
                                                  : FrameLength::fixed_at(8);
        case 0x0F:
        case 0x10:  // addr fc start qty count data
            return counted(head, 6);
        case 0x14:
        case 0x15:
            return counted(head, 2);
        case 0x16:
            return FrameLength::fixed_at(10);
        case 0x17:  // addr fc rstart rqty wstart wqty count data
            return counted(head, 10);
        case 0x18:
            return FrameLength::fixed_at(6);
        case 0x2B:
            if (head.size() < 3) return FrameLength::need(3);
            return head[2] == 0x0E ? FrameLength::fixed_at(7) : FrameLength::search_crc();
        default:
            // An exception code is never sent as a request.
            return (fc & 0x80U) ? FrameLength::no_reading() : FrameLength::search_crc();
    }
}

FrameLength response_length(std::span<const std::uint8_t> head) {
    const std::uint8_t fc = head[1];
    if (fc & 0x80U) return FrameLength::fixed_at(5);  // addr, fc|0x80, exception code, CRC
    switch (fc) {
        case 0x01:
        case 0x02:
        case 0x03:
        case 0x04:
        case 0x0C:
        case 0x11:
        case 0x14:
        case 0x15:
        case 0x17:
            return counted(head, 2);
        case 0x05:
        case 0x06:
        case 0x0B:
        case 0x0F:
        case 0x10:
            return FrameLength::fixed_at(8);
        case 0x07:
            return FrameLength::fixed_at(5);
        case 0x08:
            return request_length(head);  // an echo
        case 0x16:
            return FrameLength::fixed_at(10);
        case 0x18: {  // addr fc count(2) fifo-count(2) values; count covers fifo-count+values
            if (head.size() < 4) return FrameLength::need(4);
            const std::size_t count = (std::size_t{head[2]} << 8) | head[3];
            return checked(4 + count + 2);
        }
        case 0x2B:
            if (head.size() < 3) return FrameLength::need(3);
            return head[2] == 0x0E ? device_identification_answer(head) : FrameLength::search_crc();
        default:
            return FrameLength::search_crc();
    }
}

}  // namespace

FrameLengths ProtocolRules::frame_lengths(std::span<const std::uint8_t> head) const {
    if (head.size() < 2) return {FrameLength::need(2), FrameLength::need(2)};
    return {request_length(head), response_length(head)};
}

bool ProtocolRules::answer_is_echo(std::uint8_t /*slave*/, std::uint8_t function) const {
    switch (function) {
        case 0x05:
        case 0x06:
        case 0x08:
        case 0x15:
        case 0x16:
            return true;
        default:
            return false;
    }
}

bool ProtocolRules::is_broadcast(std::uint8_t slave) const {
    return slave == 0;
}

bool ProtocolRules::expects_answer(std::uint8_t /*slave*/, std::uint8_t /*function*/) const {
    return true;
}

bool ProtocolRules::answers_errors(std::uint8_t /*slave*/) const {
    return true;
}

const ProtocolRules& standard_rules() {
    static const ProtocolRules rules;
    return rules;
}

}  // namespace rtuscope
