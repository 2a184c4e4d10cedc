#include "input/mbap.hpp"

namespace rtuscope {

//  0  transaction id (2)   2  protocol id (2): 0   4  length (2): unit id + PDU
//  6  unit id (1)          7  function code (1)   8  data
std::size_t mbap_adu_length(std::span<const std::uint8_t> bytes) {
    if (bytes.size() < kMbapHeaderBytes + 1) return 0;
    if (bytes[2] != 0 || bytes[3] != 0) return 0;
    const std::size_t length = (std::size_t{bytes[4]} << 8) | bytes[5];
    if (length < 2 || 6 + length > kMaxMbapAdu) return 0;
    const std::uint8_t function = bytes[7];
    if (function == 0 || function == 0x80) return 0;
    return 6 + length;
}

bool is_modbus_tcp(std::span<const std::uint8_t> payload) {
    if (payload.empty()) return false;
    while (!payload.empty()) {
        const std::size_t length = mbap_adu_length(payload);
        if (length == 0 || length > payload.size()) return false;
        payload = payload.subspan(length);
    }
    return true;
}

}  // namespace rtuscope
