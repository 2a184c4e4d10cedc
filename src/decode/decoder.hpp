// Stage 4, decoder: the standard PDUs of the Modbus Application Protocol Specification
// v1.1b3 (all public function codes, both directions, all exception codes). Unknown
// function codes decode as raw data. Decoding never throws and never reads out of
// bounds: what does not fit becomes a Note.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "framing/note.hpp"
#include "framing/protocol_rules.hpp"

namespace rtuscope {

enum class DataTable : std::uint8_t { coils, discrete_inputs, holding_registers, input_registers };

// Data items a frame carries, with their addresses, for the profile layer to explain.
// Bits (coils, discrete inputs) are one value of 0 or 1 each.
struct DataBlock {
    DataTable table = DataTable::holding_registers;
    std::uint16_t start = 0;
    std::vector<std::uint16_t> values;
    bool write = false;  // carried by a write request (or its echo)
    // A device's own register table (a profile's non-standard function code); when set it
    // replaces `table`.
    std::string custom_table;
};

struct DecodedPdu {
    std::string function_name;  // "Read Holding Registers"; "Function 0x41" when unknown
    std::string summary;        // key fields, e.g. "0x0000 x2" or "2 registers: 0x1818 0x0000"
    bool exception = false;
    std::uint8_t exception_code = 0;
    Notes notes;                    // pdu.* diagnostics
    std::vector<DataBlock> blocks;  // register/bit values, when the PDU carries any
    std::vector<DataBlock> spare_blocks;  // emptied blocks, kept for their buffers

    void clear();  // empties it, keeping the buffers for the next record
};

// `pdu` is the function code and data (no address, no CRC). `request_pdu` is the PDU of
// the request this frame answers, empty when unknown (a request, or an unpaired answer).
// Decodes into `out` (cleared first), reusing its buffers.
void decode_pdu(std::span<const std::uint8_t> pdu, Role role,
                std::span<const std::uint8_t> request_pdu, DecodedPdu& out);
DecodedPdu decode_pdu(std::span<const std::uint8_t> pdu, Role role,
                      std::span<const std::uint8_t> request_pdu = {});

// Data bytes shown as they are in a summary, "01 03 00 00": at most as many as a frame can
// hold (kMaxPduDataShown), the rest counted. A hex log line or a pcap packet can be far
// longer than Modbus allows (512 KB); all its bytes are in the frame's hex anyway, and
// three characters a byte of summary and notes took a decode past its memory bound.
inline constexpr std::size_t kMaxPduDataShown = kMaxAdu - 4;  // address, code, CRC
std::string data_bytes_text(std::span<const std::uint8_t> data);

// "Read Holding Registers"; for unknown codes "Function 0x41". fc & 0x80 is ignored.
std::string function_name(std::uint8_t function);
void append_function_name(std::string& out, std::uint8_t function);
// The specification's name, nullptr for codes it does not define.
const char* standard_function_name(std::uint8_t function);
// "Illegal Data Address"; nullptr for codes the specification does not define.
const char* exception_name(std::uint8_t code);

}  // namespace rtuscope
