// How a frame travelled: Modbus RTU, or Modbus/TCP with its MBAP header.
#pragma once

#include <cstdint>

namespace rtuscope {

// How a frame travelled. Modbus RTU: address, PDU, CRC (on a serial line, or over TCP or
// UDP as they are). Modbus/TCP (MBAP, also over UDP): an MBAP header, the unit id and the
// PDU, no CRC; the frame's bytes are the unit id and the PDU, the header's other fields
// are in Frame::mbap.
enum class Transport : std::uint8_t { rtu, tcp };

const char* to_string(Transport transport);

// A Modbus/TCP frame's MBAP header (Modbus Messaging on TCP/IP Implementation Guide
// V1.0b, 3.1.3), but its unit id, and the connection it came on: a transaction id pairs a
// request with its answer within one connection.
struct Mbap {
    std::uint16_t transaction = 0;
    // The TCP connection (or UDP exchange) by its addresses and ports, the same number
    // both ways; 0 when not known.
    std::uint32_t connection = 0;
};

}  // namespace rtuscope
