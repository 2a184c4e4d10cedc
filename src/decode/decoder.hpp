// Stage 4, decoder: the PDUs of the MODBUS Application Protocol Specification V1.1b3 (all
// public function codes, both directions, all exception codes), each decoded by its entry
// in the function table (framing/functions.hpp); a device's own function codes by their
// profile's entry. Unknown function codes decode as raw data. Decoding never throws and
// never reads out of bounds: what does not fit becomes a Note.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "framing/functions.hpp"
#include "framing/note.hpp"
#include "util/reused_list.hpp"

namespace rtuscope {

// Data items a frame carries, with their addresses, for the profile layer to explain.
// Bits (coils, discrete inputs) are one value of 0 or 1 each.
struct DataBlock {
    DataTable table = DataTable::holding_registers;
    std::uint16_t start = 0;
    std::vector<std::uint16_t> values;
    bool write = false;  // carried by a write request (or its echo)
    // A device's own register table (a profile's function code); when set it replaces
    // `table`.
    std::string custom_table;

    void clear();  // keeps the buffers
};

struct DecodedPdu {
    // The entry it was decoded by: the standard one of its code, or its device's own.
    // Points into the function table or a profile, which outlive the records.
    const FunctionSpec* function = nullptr;
    // "Read Holding Registers"; "Function 0x41" when unknown; "Read Device Identification"
    // for 2B/0E.
    std::string_view function_name;
    std::string summary;  // key fields, e.g. "0x0000 x2" or "2 registers: 0x1818 0x0000"
    bool exception = false;
    std::uint8_t exception_code = 0;
    Notes notes;                   // pdu.* diagnostics
    ReusedList<DataBlock> blocks;  // register/bit values, when the PDU carries any

    void clear();  // keeps the buffers
};

// Decodes `pdu` (function code and data, no address, no CRC) by the entry `spec` of its
// function code into `out`, which is cleared first and keeps its buffers. `request_pdu` is
// the PDU of the request this frame answers, empty when unknown (a request, or an
// unpaired answer).
void decode_pdu(const FunctionSpec& spec, std::span<const std::uint8_t> pdu, Role role,
                std::span<const std::uint8_t> request_pdu, DecodedPdu& out);

// Data bytes shown as they are in a summary, "01 03 00 00": at most as many as a frame can
// hold (kMaxPduDataShown), the rest counted. A hex log line or a pcap packet can be far
// longer than Modbus allows (512 KB); all its bytes are in the frame's hex anyway, and
// three characters a byte of summary and notes would take a decode past its memory bound.
inline constexpr std::size_t kMaxPduDataShown = kMaxAdu - 4;  // address, code, CRC
void append_data_bytes(std::string& out, std::span<const std::uint8_t> data);

// "Illegal Data Address"; nullptr for codes the specification does not define (section 7).
const char* exception_name(std::uint8_t code);

}  // namespace rtuscope
