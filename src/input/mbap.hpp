// Modbus/TCP recognition: the MBAP header (Modbus Messaging on TCP/IP Implementation
// Guide V1.0b, section 3.1.3) in front of a PDU. The pcap reader tells Modbus/TCP
// payloads from Modbus RTU and from other protocols by this header, and cuts a stream of
// them into ADUs.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

namespace rtuscope {

// transaction id (2), protocol id (2), length (2), unit id (1)
inline constexpr std::size_t kMbapHeaderBytes = 7;
// The length field counts the unit id and the PDU: 1 + at most 253.
inline constexpr std::size_t kMaxMbapAdu = 6 + 1 + 253;

// The length of the Modbus/TCP ADU (MBAP header and PDU) that `bytes` start with, as its
// header gives it: 0 unless the header is one (protocol id 0, a length field of 2 to
// 254, a function code other than 0 and 0x80). The ADU may run past the bytes given.
std::size_t mbap_adu_length(std::span<const std::uint8_t> bytes);

// Whether `payload` is one or more whole Modbus/TCP ADUs back to back, each length field
// matching the bytes that follow it.
bool is_modbus_tcp(std::span<const std::uint8_t> payload);

}  // namespace rtuscope
