// Decoder tests. The PDUs are the examples of the MODBUS Application Protocol
// Specification V1.1b3 (section numbers given per case), plus broken variants of them.
// Most cases are rows of one table (kCases), each a PDU, its role, the request it answers
// and what the decoder must make of it, run by one parameterized test. Loops over many
// codes, and checks of functions other than decode_pdu(), are hand-written tests after it.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <optional>
#include <ostream>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "decode/decoder.hpp"

namespace rtuscope {
namespace {

using Bytes = std::vector<std::uint8_t>;
using Ids = std::vector<std::string>;

// The PDU decoded by its standard function entry.
DecodedPdu decode(const Bytes& pdu, Role role, const Bytes& asked = {}) {
    DecodedPdu d;
    decode_pdu(standard_function(pdu.empty() ? 0 : pdu[0]), pdu, role, asked, d);
    return d;
}

DecodedPdu request(const Bytes& pdu) {
    return decode(pdu, Role::request);
}

DecodedPdu response(const Bytes& pdu, const Bytes& asked = {}) {
    return decode(pdu, Role::response, asked);
}

std::string data_bytes(std::span<const std::uint8_t> data) {
    std::string text;
    append_data_bytes(text, data);
    return text;
}

Ids ids(const DecodedPdu& d) {
    Ids out;
    for (const Note& n : d.notes) out.emplace_back(n.id);
    return out;
}

std::string texts(const DecodedPdu& d) {
    std::string out;
    for (const Note& n : d.notes) out += n.text + ";";
    return out;
}

// DataTable in gtest's messages (its bytes otherwise).
std::string table_name(DataTable table) {
    switch (table) {
        case DataTable::none:
            return "none";
        case DataTable::coils:
            return "coils";
        case DataTable::discrete_inputs:
            return "discrete_inputs";
        case DataTable::holding_registers:
            return "holding_registers";
        case DataTable::input_registers:
            return "input_registers";
    }
    return "table " + std::to_string(static_cast<int>(table));
}

// ---- Building PDUs at table-construction time ----

// `head` followed by `n` bytes of `fill`.
Bytes padded(Bytes head, std::size_t n, std::uint8_t fill) {
    head.insert(head.end(), n, fill);
    return head;
}

// `head` followed by the registers 0, 1, ... n-1.
Bytes counting_registers(Bytes head, std::uint8_t n) {
    for (std::uint8_t i = 0; i < n; ++i) {
        head.push_back(0);
        head.push_back(i);
    }
    return head;
}

// `pdu` with its last byte changed: an echo that differs from its request.
Bytes with_last(Bytes pdu, std::uint8_t last) {
    pdu.back() = last;
    return pdu;
}

Bytes with_text(Bytes head, std::string_view text) {
    head.insert(head.end(), text.begin(), text.end());
    return head;
}

// `head` followed by Read Device Identification objects: id, length, text.
Bytes with_objects(Bytes head,
                   std::initializer_list<std::pair<std::uint8_t, std::string_view>> objects) {
    for (const auto& [id, text] : objects) {
        head.push_back(id);
        head.push_back(static_cast<std::uint8_t>(text.size()));
        head = with_text(std::move(head), text);
    }
    return head;
}

// ---- The specification's examples that several cases use ----

const Bytes kReadCoils{0x01, 0x00, 0x13, 0x00, 0x13};
const Bytes kReadInputs{0x02, 0x00, 0xC4, 0x00, 0x16};
const Bytes kReadHolding{0x03, 0x00, 0x6B, 0x00, 0x03};
const Bytes kReadInputRegisters{0x04, 0x00, 0x08, 0x00, 0x01};
const Bytes kWriteCoil{0x05, 0x00, 0xAC, 0xFF, 0x00};
const Bytes kWriteRegister{0x06, 0x00, 0x01, 0x00, 0x03};
const Bytes kReturnQueryData{0x08, 0x00, 0x00, 0xA5, 0x37};
const Bytes kBusMessageCount{0x08, 0x00, 0x0B, 0x00, 0x00};
const Bytes kWriteCoils{0x0F, 0x00, 0x13, 0x00, 0x0A, 0x02, 0xCD, 0x01};
const Bytes kWriteRegisters{0x10, 0x00, 0x01, 0x00, 0x02, 0x04, 0x00, 0x0A, 0x01, 0x02};
const Bytes kReadFile{0x14, 0x0E, 0x06, 0x00, 0x04, 0x00, 0x01, 0x00,
                      0x02, 0x06, 0x00, 0x03, 0x00, 0x09, 0x00, 0x02};
const Bytes kReadFileAnswer{0x14, 0x0C, 0x05, 0x06, 0x0D, 0xFE, 0x00,
                            0x20, 0x05, 0x06, 0x33, 0xCD, 0x00, 0x40};
const Bytes kWriteFile{0x15, 0x0D, 0x06, 0x00, 0x04, 0x00, 0x07, 0x00,
                       0x03, 0x06, 0xAF, 0x04, 0xBE, 0x10, 0x0D};
const Bytes kMaskWrite{0x16, 0x00, 0x04, 0x00, 0xF2, 0x00, 0x25};
const Bytes kReadWrite{0x17, 0x00, 0x03, 0x00, 0x06, 0x00, 0x0E, 0x00,
                       0x03, 0x06, 0x00, 0xFF, 0x00, 0xFF, 0x00, 0xFF};
const Bytes kReadDeviceId{0x2B, 0x0E, 0x01, 0x00};

// Return Query Data with far more data than a frame can hold (a hex log line or a pcap
// packet can be that long), and its echo with the last byte changed.
const Bytes kLongQueryData = padded({0x08, 0x00, 0x00}, 300'000, 0x11);
const Bytes kLongQueryEcho = with_last(kLongQueryData, 0x22);

// ---- One case per row ----

struct ExpectedNote {
    std::string id;
    std::optional<std::string> text;  // checked when given
};

struct ExpectedBlock {
    DataTable table;
    std::uint16_t start;
    std::vector<std::uint16_t> values;
    bool write;
};

// A PDU, decoded as a request or as a response, and what the decoder must give. The
// summary (every row gives one), the note ids (none unless given), the data block (none
// unless given) and whether it is an exception are always checked; the function name and
// a note's text when given. Rows are built with as_request() / as_response() and the setters below.
struct Case {
    std::string section;  // of the specification: "6.1"
    std::string name;     // the test's name: "ReadCoils_Request"
    Role role = Role::request;
    Bytes pdu;
    Bytes asked;  // the PDU of the request it answers; empty for none

    std::optional<std::string> expected_summary;  // every row gives one
    std::vector<ExpectedNote> expected_notes;
    std::optional<ExpectedBlock> expected_block;
    std::string expected_function;  // checked when not empty
    std::optional<std::uint8_t> expected_exception;

    Case summary(std::string text) && {
        expected_summary = std::move(text);
        return std::move(*this);
    }
    Case note(std::string id) && {
        expected_notes.push_back({std::move(id), std::nullopt});
        return std::move(*this);
    }
    Case note(std::string id, std::string text) && {
        expected_notes.push_back({std::move(id), std::move(text)});
        return std::move(*this);
    }
    // The one data block: values read (a read's answer), or written (a write request or
    // its echo).
    Case reads(DataTable table, std::uint16_t start, std::vector<std::uint16_t> values) && {
        expected_block = ExpectedBlock{table, start, std::move(values), false};
        return std::move(*this);
    }
    Case writes(DataTable table, std::uint16_t start, std::vector<std::uint16_t> values) && {
        expected_block = ExpectedBlock{table, start, std::move(values), true};
        return std::move(*this);
    }
    Case function(std::string name_of_function) && {
        expected_function = std::move(name_of_function);
        return std::move(*this);
    }
    Case exception(std::uint8_t code) && {
        expected_exception = code;
        return std::move(*this);
    }
};

Case as_request(std::string section, std::string name, Bytes pdu) {
    Case c;
    c.section = std::move(section);
    c.name = std::move(name);
    c.role = Role::request;
    c.pdu = std::move(pdu);
    return c;
}

Case as_response(std::string section, std::string name, Bytes pdu, Bytes asked = {}) {
    Case c = as_request(std::move(section), std::move(name), std::move(pdu));
    c.role = Role::response;
    c.asked = std::move(asked);
    return c;
}

// The case in a failure's trace: "6.1 ReadCoils_Request: request 01 00 13 00 13", then
// the request it answers; at most a frame's worth of each PDU's bytes shown.
std::string describe(const Case& c) {
    std::string out = c.section + " " + c.name + ": ";
    out += c.role == Role::request ? "request " : "response ";
    append_data_bytes(out, c.pdu);
    if (!c.asked.empty()) {
        out += " to the request ";
        append_data_bytes(out, c.asked);
    }
    return out;
}

// For gtest's messages and ctest's test list (its bytes otherwise). ctest adds it to each
// case's name, so it stays short: the section, the role and the PDU's first 16 bytes.
void PrintTo(const Case& c, std::ostream* out) {
    constexpr std::size_t kShown = 16;
    std::string text = c.section + (c.role == Role::request ? " request " : " response ");
    append_data_bytes(text, std::span(c.pdu).first(std::min(c.pdu.size(), kShown)));
    if (c.pdu.size() > kShown) text += fmt::format(" ... ({} bytes)", c.pdu.size());
    *out << text;
}

// clang-format off
const std::vector<Case> kCases{
    // 4.1 The PDU: a function code, then data
    as_request("4.1", "EmptyPdu_Request", {})
        .summary("").note("pdu.malformed"),
    as_response("4.1", "EmptyPdu_Response", {}, {0x03, 0x00, 0x00, 0x00, 0x01})
        .summary("").note("pdu.malformed"),

    // 5 Function codes without an entry: the data shown as bytes. 0x41 is user-defined,
    // 0x09 one the specification reserves (annex A).
    as_request("5", "UnknownFunction_DataShownAsHex", {0x41, 0x2A, 0x00, 0x15})
        .function("Function 0x41").summary("2A 00 15")
        .note("pdu.unknown_function", "user-defined function code 0x41"),
    as_response("5", "UnknownFunction_CodeOnly", {0x09})
        .function("Function 0x09").summary("")
        .note("pdu.unknown_function", "reserved function code 0x09"),

    // 6.1 Read Coils (01)
    as_request("6.1", "ReadCoils_Request", kReadCoils)
        .function("Read Coils").summary("0x0013 x19"),
    // With the request, exactly the coils asked; without it, every bit of the data bytes
    // and no block, as the start address is unknown.
    as_response("6.1", "ReadCoils_ResponseWithRequestShowsExactlyTheQuantity",
                {0x01, 0x03, 0xCD, 0x6B, 0x05}, kReadCoils)
        .summary("19 coils: 1011001111010110101")
        .reads(DataTable::coils, 0x0013,
               {1, 0, 1, 1, 0, 0, 1, 1, 1, 1, 0, 1, 0, 1, 1, 0, 1, 0, 1}),
    as_response("6.1", "ReadCoils_ResponseWithoutRequestShowsEveryBitAndNoBlock",
                {0x01, 0x03, 0xCD, 0x6B, 0x05})
        .summary("24 coils: 101100111101011010100000"),
    as_response("6.1", "ReadCoils_ByteCountDisagreesWithRequest", {0x01, 0x02, 0xCD, 0x6B},
                kReadCoils)
        .summary("16 coils: 1011001111010110")
        .note("pdu.byte_count_mismatch", "byte count 2, 19 coils asked need 3")
        .reads(DataTable::coils, 0x0013, {1, 0, 1, 1, 0, 0, 1, 1, 1, 1, 0, 1, 0, 1, 1, 0}),
    as_request("6.1", "ReadCoils_Quantity2000IsLegal", {0x01, 0x00, 0x00, 0x07, 0xD0})
        .summary("0x0000 x2000"),
    as_request("6.1", "ReadCoils_Quantity2001IsIllegal", {0x01, 0x00, 0x00, 0x07, 0xD1})
        .summary("0x0000 x2001")
        .note("pdu.illegal_value", "quantity 2001 out of range 1..2000"),
    // 80 coils fill exactly 10 bytes: no note. The summary shows 64 of them.
    as_response("6.1", "ReadCoils_LongListIsCutInTheSummaryButNotInTheBlock",
                padded({0x01, 0x0A}, 10, 0xFF), {0x01, 0x00, 0x00, 0x00, 0x50})
        .summary("80 coils: " + std::string(64, '1') + " ... (+16 more)")
        .reads(DataTable::coils, 0x0000, std::vector<std::uint16_t>(80, 1)),

    // 6.2 Read Discrete Inputs (02)
    as_request("6.2", "ReadDiscreteInputs_Request", kReadInputs)
        .function("Read Discrete Inputs").summary("0x00C4 x22"),
    as_response("6.2", "ReadDiscreteInputs_Response", {0x02, 0x03, 0xAC, 0xDB, 0x35},
                kReadInputs)
        .summary("22 inputs: 0011010111011011101011")
        .reads(DataTable::discrete_inputs, 0x00C4,
               {0, 0, 1, 1, 0, 1, 0, 1, 1, 1, 0, 1, 1, 0, 1, 1, 1, 0, 1, 0, 1, 1}),

    // 6.3 Read Holding Registers (03)
    as_request("6.3", "ReadHoldingRegisters_Request", kReadHolding)
        .function("Read Holding Registers").summary("0x006B x3"),
    as_response("6.3", "ReadHoldingRegisters_Response",
                {0x03, 0x06, 0x02, 0x2B, 0x00, 0x00, 0x00, 0x64}, kReadHolding)
        .summary("3 registers: 0x022B 0x0000 0x0064")
        .reads(DataTable::holding_registers, 0x006B, {0x022B, 0x0000, 0x0064}),
    as_response("6.3", "ReadHoldingRegisters_ResponseWithoutRequestHasNoBlock",
                {0x03, 0x04, 0x18, 0x18, 0x00, 0x00})
        .summary("2 registers: 0x1818 0x0000"),
    // The registers that came are still the ones asked from the start address on.
    as_response("6.3", "ReadHoldingRegisters_AnswerShorterThanAsked", {0x03, 0x02, 0x18, 0x18},
                {0x03, 0x00, 0x00, 0x00, 0x02})
        .summary("1 register: 0x1818")
        .note("pdu.byte_count_mismatch", "byte count 2, 2 registers asked need 4")
        .reads(DataTable::holding_registers, 0x0000, {0x1818}),
    as_response("6.3", "ReadHoldingRegisters_ByteCountDisagreesWithDataPresent",
                {0x03, 0x06, 0x00, 0x01, 0x00, 0x02})
        .summary("2 registers: 0x0001 0x0002")
        .note("pdu.byte_count_mismatch", "byte count 6, 4 bytes present"),
    as_response("6.3", "ReadHoldingRegisters_OddByteCount", {0x03, 0x03, 0x00, 0x01, 0x02})
        .summary("1 register: 0x0001").note("pdu.malformed"),
    as_response("6.3", "ReadHoldingRegisters_ByteCountBeyondTheData", {0x03, 0xFA, 0x00, 0x01},
                {0x03, 0x00, 0x00, 0x00, 0x7D})
        .summary("1 register: 0x0001").note("pdu.byte_count_mismatch")
        .reads(DataTable::holding_registers, 0x0000, {0x0001}),
    as_request("6.3", "ReadHoldingRegisters_Quantity0IsIllegal", {0x03, 0x00, 0x00, 0x00, 0x00})
        .summary("0x0000 x0").note("pdu.illegal_value", "quantity 0 out of range 1..125"),
    as_request("6.3", "ReadHoldingRegisters_Quantity125IsLegal", {0x03, 0x00, 0x00, 0x00, 0x7D})
        .summary("0x0000 x125"),
    as_request("6.3", "ReadHoldingRegisters_Quantity126IsIllegal",
               {0x03, 0x00, 0x00, 0x00, 0x7E})
        .summary("0x0000 x126").note("pdu.illegal_value"),
    as_request("6.3", "ReadHoldingRegisters_RangePastTheLastAddress",
               {0x03, 0xFF, 0xFF, 0x00, 0x02})
        .summary("0xFFFF x2").note("pdu.illegal_value", "0xFFFF x2 runs past address 0xFFFF"),
    as_request("6.3", "ReadHoldingRegisters_RequestTooLong",
               {0x03, 0x00, 0x00, 0x00, 0x02, 0x00})
        .summary("0x0000 x2")
        .note("pdu.malformed", "PDU too long: 5 bytes expected, 6 present"),
    as_request("6.3", "ReadHoldingRegisters_RequestTooShort", {0x03, 0x00, 0x10, 0x00})
        .summary("0x0010")
        .note("pdu.malformed", "PDU too short: 5 bytes expected, 4 present"),
    as_response("6.3", "ReadHoldingRegisters_LongListIsCut", counting_registers({0x03, 20}, 10),
                {0x03, 0x00, 0x00, 0x00, 0x0A})
        .summary("10 registers: 0x0000 0x0001 0x0002 0x0003 0x0004 0x0005 0x0006 0x0007 "
                 "... (+2 more)")
        .reads(DataTable::holding_registers, 0x0000, {0, 1, 2, 3, 4, 5, 6, 7, 8, 9}),
    // No block: the request's start address does not apply.
    as_response("6.3", "ReadHoldingRegisters_AnswerToAnotherFunction", {0x03, 0x02, 0x00, 0x01},
                {0x04, 0x00, 0x00, 0x00, 0x01})
        .summary("1 register: 0x0001").note("pdu.request_mismatch"),

    // 6.4 Read Input Registers (04)
    as_request("6.4", "ReadInputRegisters_Request", kReadInputRegisters)
        .function("Read Input Registers").summary("0x0008 x1"),
    as_response("6.4", "ReadInputRegisters_Response", {0x04, 0x02, 0x00, 0x0A},
                kReadInputRegisters)
        .summary("1 register: 0x000A")
        .reads(DataTable::input_registers, 0x0008, {0x000A}),

    // 6.5 Write Single Coil (05)
    as_request("6.5", "WriteSingleCoil_RequestOn", kWriteCoil)
        .function("Write Single Coil").summary("0x00AC ON")
        .writes(DataTable::coils, 0x00AC, {1}),
    as_response("6.5", "WriteSingleCoil_EchoOff", {0x05, 0x00, 0xAC, 0x00, 0x00},
                {0x05, 0x00, 0xAC, 0x00, 0x00})
        .summary("0x00AC OFF")
        .writes(DataTable::coils, 0x00AC, {0}),
    as_response("6.5", "WriteSingleCoil_EchoDiffersFromRequest", {0x05, 0x00, 0xAC, 0x00, 0x00},
                kWriteCoil)
        .summary("0x00AC OFF").note("pdu.request_mismatch", "request was 0x00AC ON")
        .writes(DataTable::coils, 0x00AC, {0}),
    // Neither ON (FF 00) nor OFF (00 00): no value to put in a block.
    as_request("6.5", "WriteSingleCoil_IllegalValue", {0x05, 0x00, 0xAC, 0x12, 0x34})
        .summary("0x00AC 0x1234").note("pdu.illegal_value"),

    // 6.6 Write Single Register (06)
    as_request("6.6", "WriteSingleRegister_Request", kWriteRegister)
        .function("Write Single Register").summary("0x0001 = 0x0003 (3)")
        .writes(DataTable::holding_registers, 0x0001, {0x0003}),
    as_response("6.6", "WriteSingleRegister_Echo", kWriteRegister, kWriteRegister)
        .summary("0x0001 = 0x0003 (3)")
        .writes(DataTable::holding_registers, 0x0001, {0x0003}),
    as_response("6.6", "WriteSingleRegister_EchoToAnotherAddress",
                {0x06, 0x00, 0x02, 0x00, 0x03}, kWriteRegister)
        .summary("0x0002 = 0x0003 (3)")
        .note("pdu.request_mismatch", "request was 0x0001 = 0x0003 (3)")
        .writes(DataTable::holding_registers, 0x0002, {0x0003}),

    // 6.7 Read Exception Status (07)
    as_request("6.7", "ReadExceptionStatus_Request", {0x07})
        .function("Read Exception Status").summary(""),
    as_response("6.7", "ReadExceptionStatus_Response", {0x07, 0x6D}, {0x07})
        .summary("status 0x6D"),
    as_request("6.7", "ReadExceptionStatus_RequestWithData", {0x07, 0x00})
        .summary("").note("pdu.malformed"),

    // 6.8 Diagnostics (08)
    as_request("6.8", "Diagnostics_ReturnQueryDataRequest", kReturnQueryData)
        .function("Diagnostics").summary("Return Query Data 0xA537"),
    as_response("6.8", "Diagnostics_ReturnQueryDataEcho", kReturnQueryData, kReturnQueryData)
        .summary("Return Query Data 0xA537"),
    // Return Query Data takes any number of bytes, not only the example's two.
    as_request("6.8", "Diagnostics_ReturnQueryDataAnyLength",
               {0x08, 0x00, 0x00, 0x01, 0x02, 0x03})
        .summary("Return Query Data 01 02 03"),
    as_response("6.8", "Diagnostics_ReturnQueryDataEchoDiffers",
                {0x08, 0x00, 0x00, 0xA5, 0x38}, kReturnQueryData)
        .summary("Return Query Data 0xA538").note("pdu.request_mismatch"),
    // Beyond what a frame can hold, the summary and the note show a frame's worth of
    // bytes and count the rest (300,000 - 252).
    as_response("6.8", "Diagnostics_EchoOfDataBeyondALegalFrameIsCounted", kLongQueryEcho,
                kLongQueryData)
        .summary("Return Query Data " +
                 data_bytes(std::span(kLongQueryEcho).subspan(3, kMaxPduDataShown)) +
                 " ... (+299748 more)")
        .note("pdu.request_mismatch",
              "echo differs from the request (" +
                  data_bytes(std::span(kLongQueryData).subspan(3, kMaxPduDataShown)) +
                  " ... (+299748 more))"),
    as_request("6.8", "Diagnostics_BusMessageCountRequest", kBusMessageCount)
        .summary("Return Bus Message Count 0x0000"),
    as_response("6.8", "Diagnostics_BusMessageCountResponse", {0x08, 0x00, 0x0B, 0x01, 0x08},
                kBusMessageCount)
        .summary("Return Bus Message Count 0x0108"),
    as_response("6.8", "Diagnostics_AnswerWithAnotherCounter", {0x08, 0x00, 0x0C, 0x00, 0x01},
                kBusMessageCount)
        .summary("Return Bus Communication Error Count 0x0001").note("pdu.request_mismatch"),
    // Restart Communications Option takes FF 00 (clear the event log) or 00 00; Change
    // ASCII Input Delimiter a character and 00; the counters 00 00.
    as_request("6.8", "Diagnostics_RestartClearingTheLogIsLegal", {0x08, 0x00, 0x01, 0xFF, 0x00})
        .summary("Restart Communications Option 0xFF00"),
    as_request("6.8", "Diagnostics_RestartWithOtherDataIsIllegal",
               {0x08, 0x00, 0x01, 0x12, 0x34})
        .summary("Restart Communications Option 0x1234").note("pdu.illegal_value"),
    as_request("6.8", "Diagnostics_DelimiterIsLegal", {0x08, 0x00, 0x03, 0x0A, 0x00})
        .summary("Change ASCII Input Delimiter 0x0A00"),
    as_request("6.8", "Diagnostics_DelimiterWithoutTrailingZeroIsIllegal",
               {0x08, 0x00, 0x03, 0x0A, 0x01})
        .summary("Change ASCII Input Delimiter 0x0A01").note("pdu.illegal_value"),
    as_request("6.8", "Diagnostics_CounterRequestWithDataIsIllegal",
               {0x08, 0x00, 0x0B, 0x00, 0x01})
        .summary("Return Bus Message Count 0x0001").note("pdu.illegal_value"),
    as_request("6.8", "Diagnostics_CounterRequestCutShort", {0x08, 0x00, 0x0B, 0x00})
        .summary("Return Bus Message Count 00").note("pdu.malformed"),
    as_request("6.8", "Diagnostics_ReservedSubFunction", {0x08, 0x00, 0x05, 0x00, 0x00})
        .summary("sub-function 0x0005 0x0000").note("pdu.unknown_function"),

    // 6.9 Get Comm Event Counter (0B)
    as_request("6.9", "GetCommEventCounter_Request", {0x0B})
        .function("Get Comm Event Counter").summary(""),
    as_response("6.9", "GetCommEventCounter_Response", {0x0B, 0xFF, 0xFF, 0x01, 0x08}, {0x0B})
        .summary("status 0xFFFF, event count 264"),
    as_response("6.9", "GetCommEventCounter_ShortResponse", {0x0B, 0x00, 0x00, 0x01})
        .summary("status 0x0000").note("pdu.malformed"),

    // 6.10 Get Comm Event Log (0C)
    as_request("6.10", "GetCommEventLog_Request", {0x0C})
        .function("Get Comm Event Log").summary(""),
    as_response("6.10", "GetCommEventLog_Response",
                {0x0C, 0x08, 0x00, 0x00, 0x01, 0x08, 0x01, 0x21, 0x20, 0x00}, {0x0C})
        .summary("status 0x0000, event count 264, message count 289, 2 events: 20 00"),
    // A byte count of 2 cannot hold the status and the two counters.
    as_response("6.10", "GetCommEventLog_ByteCountTooSmall", {0x0C, 0x02, 0x00, 0x00})
        .summary("status 0x0000").note("pdu.malformed"),

    // 6.11 Write Multiple Coils (0F)
    as_request("6.11", "WriteMultipleCoils_Request", kWriteCoils)
        .function("Write Multiple Coils").summary("0x0013 x10: 1011001110")
        .writes(DataTable::coils, 0x0013, {1, 0, 1, 1, 0, 0, 1, 1, 1, 0}),
    // The answer repeats the address and quantity only: no values, no block.
    as_response("6.11", "WriteMultipleCoils_Response", {0x0F, 0x00, 0x13, 0x00, 0x0A},
                kWriteCoils)
        .summary("0x0013 x10"),
    as_response("6.11", "WriteMultipleCoils_ResponseQuantityDiffers",
                {0x0F, 0x00, 0x13, 0x00, 0x09}, kWriteCoils)
        .summary("0x0013 x9").note("pdu.request_mismatch", "request was 0x0013 x10"),
    as_request("6.11", "WriteMultipleCoils_ByteCountDisagreesWithQuantity",
               {0x0F, 0x00, 0x13, 0x00, 0x0A, 0x01, 0xCD})
        .summary("0x0013 x10: 10110011")
        .note("pdu.byte_count_mismatch", "byte count 1, 10 coils need 2")
        .writes(DataTable::coils, 0x0013, {1, 0, 1, 1, 0, 0, 1, 1}),
    // 1969 coils need 247 bytes: the byte count agrees, only the quantity is illegal.
    as_request("6.11", "WriteMultipleCoils_QuantityLimit",
               padded({0x0F, 0x00, 0x00, 0x07, 0xB1, 247}, 247, 0x00))
        .summary("0x0000 x1969: " + std::string(64, '0') + " ... (+1905 more)")
        .note("pdu.illegal_value")
        .writes(DataTable::coils, 0x0000, std::vector<std::uint16_t>(1969, 0)),

    // 6.12 Write Multiple Registers (10)
    as_request("6.12", "WriteMultipleRegisters_Request", kWriteRegisters)
        .function("Write Multiple Registers").summary("0x0001 x2: 0x000A 0x0102")
        .writes(DataTable::holding_registers, 0x0001, {0x000A, 0x0102}),
    as_response("6.12", "WriteMultipleRegisters_Response", {0x10, 0x00, 0x01, 0x00, 0x02},
                kWriteRegisters)
        .summary("0x0001 x2"),
    as_request("6.12", "WriteMultipleRegisters_ByteCountAndDataDisagree",
               {0x10, 0x00, 0x01, 0x00, 0x02, 0x04, 0x00, 0x0A})
        .summary("0x0001 x2: 0x000A")
        .note("pdu.byte_count_mismatch", "byte count 4, 2 bytes present")
        .writes(DataTable::holding_registers, 0x0001, {0x000A}),
    as_request("6.12", "WriteMultipleRegisters_QuantityLimit",
               padded({0x10, 0x00, 0x00, 0x00, 0x7C, 248}, 248, 0x00))
        .summary("0x0000 x124: 0x0000 0x0000 0x0000 0x0000 0x0000 0x0000 0x0000 0x0000 "
                 "... (+116 more)")
        .note("pdu.illegal_value", "quantity 124 out of range 1..123")
        .writes(DataTable::holding_registers, 0x0000, std::vector<std::uint16_t>(124, 0)),

    // 6.13 Report Server ID (11)
    as_request("6.13", "ReportServerId_Request", {0x11})
        .function("Report Server ID").summary(""),
    as_response("6.13", "ReportServerId_Response", {0x11, 0x03, 0x01, 0x02, 0xFF}, {0x11})
        .summary("3 bytes: 01 02 FF"),

    // 6.14 Read File Record (14)
    as_request("6.14", "ReadFileRecord_Request", kReadFile)
        .function("Read File Record")
        .summary("2 sub-requests: file 4 record 0x0001 x2, file 3 record 0x0009 x2"),
    as_response("6.14", "ReadFileRecord_ResponseWithRequest", kReadFileAnswer, kReadFile)
        .summary("2 sub-responses: file 4 record 0x0001 x2: 0x0DFE 0x0020, "
                 "file 3 record 0x0009 x2: 0x33CD 0x0040"),
    as_response("6.14", "ReadFileRecord_ResponseWithoutRequest", kReadFileAnswer)
        .summary("2 sub-responses: 0x0DFE 0x0020, 0x33CD 0x0040"),
    as_response("6.14", "ReadFileRecord_FewerSubResponsesThanAsked",
                {0x14, 0x06, 0x05, 0x06, 0x0D, 0xFE, 0x00, 0x20}, kReadFile)
        .summary("1 sub-response: file 4 record 0x0001 x2: 0x0DFE 0x0020")
        .note("pdu.request_mismatch", "1 sub-response, 2 asked"),
    as_request("6.14", "ReadFileRecord_BadReferenceTypeAndRecordNumber",
               {0x14, 0x07, 0x05, 0x00, 0x04, 0x27, 0x10, 0x00, 0x02})
        .summary("1 sub-request: file 4 record 0x2710 x2")
        .note("pdu.illegal_value", "sub-request 1: reference type 0x05, 0x06 required")
        .note("pdu.illegal_value", "sub-request 1: record number 0x2710 above 0x270F"),

    // 6.15 Write File Record (15)
    as_request("6.15", "WriteFileRecord_Request", kWriteFile)
        .function("Write File Record")
        .summary("1 sub-request: file 4 record 0x0007 x3: 0x06AF 0x04BE 0x100D"),
    as_response("6.15", "WriteFileRecord_Echo", kWriteFile, kWriteFile)
        .summary("1 sub-request: file 4 record 0x0007 x3: 0x06AF 0x04BE 0x100D"),
    as_response("6.15", "WriteFileRecord_EchoDiffers", with_last(kWriteFile, 0x0E), kWriteFile)
        .summary("1 sub-request: file 4 record 0x0007 x3: 0x06AF 0x04BE 0x100E")
        .note("pdu.request_mismatch"),
    as_request("6.15", "WriteFileRecord_RecordDataCutShort",
               {0x15, 0x0B, 0x06, 0x00, 0x04, 0x00, 0x07, 0x00, 0x03, 0x06, 0xAF, 0x04, 0xBE})
        .summary("1 sub-request: file 4 record 0x0007 x3: 0x06AF 0x04BE")
        .note("pdu.malformed"),

    // 6.16 Mask Write Register (16)
    as_request("6.16", "MaskWriteRegister_Request", kMaskWrite)
        .function("Mask Write Register").summary("0x0004 AND 0x00F2 OR 0x0025"),
    as_response("6.16", "MaskWriteRegister_Echo", kMaskWrite, kMaskWrite)
        .summary("0x0004 AND 0x00F2 OR 0x0025"),
    as_response("6.16", "MaskWriteRegister_EchoDiffers",
                {0x16, 0x00, 0x04, 0x00, 0xF2, 0x00, 0x26}, kMaskWrite)
        .summary("0x0004 AND 0x00F2 OR 0x0026").note("pdu.request_mismatch"),

    // 6.17 Read/Write Multiple Registers (17)
    // The request's block is what it writes; the answer's what it reads.
    as_request("6.17", "ReadWriteMultipleRegisters_Request", kReadWrite)
        .function("Read/Write Multiple Registers")
        .summary("read 0x0003 x6, write 0x000E x3: 0x00FF 0x00FF 0x00FF")
        .writes(DataTable::holding_registers, 0x000E, {0x00FF, 0x00FF, 0x00FF}),
    as_response("6.17", "ReadWriteMultipleRegisters_Response",
                {0x17, 0x0C, 0x00, 0xFE, 0x0A, 0xCD, 0x00, 0x01,
                 0x00, 0x03, 0x00, 0x0D, 0x00, 0xFF}, kReadWrite)
        .summary("6 registers: 0x00FE 0x0ACD 0x0001 0x0003 0x000D 0x00FF")
        .reads(DataTable::holding_registers, 0x0003,
               {0x00FE, 0x0ACD, 0x0001, 0x0003, 0x000D, 0x00FF}),
    as_request("6.17", "ReadWriteMultipleRegisters_WriteQuantityLimit",
               padded({0x17, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x7A, 244}, 244, 0x00))
        .summary("read 0x0000 x1, write 0x0000 x122: 0x0000 0x0000 0x0000 0x0000 0x0000 "
                 "0x0000 0x0000 0x0000 ... (+114 more)")
        .note("pdu.illegal_value", "write quantity 122 out of range 1..121")
        .writes(DataTable::holding_registers, 0x0000, std::vector<std::uint16_t>(122, 0)),

    // 6.18 Read FIFO Queue (18)
    as_request("6.18", "ReadFifoQueue_Request", {0x18, 0x04, 0xDE})
        .function("Read FIFO Queue").summary("FIFO 0x04DE"),
    as_response("6.18", "ReadFifoQueue_Response",
                {0x18, 0x00, 0x06, 0x00, 0x02, 0x01, 0xB8, 0x12, 0x84}, {0x18, 0x04, 0xDE})
        .summary("2 values: 0x01B8 0x1284"),
    // A FIFO count of 3 in a byte count of 6 (the count and 2 values): the values the
    // bytes hold are shown.
    as_response("6.18", "ReadFifoQueue_CountDisagreesWithByteCount",
                {0x18, 0x00, 0x06, 0x00, 0x03, 0x01, 0xB8, 0x12, 0x84})
        .summary("2 values: 0x01B8 0x1284")
        .note("pdu.byte_count_mismatch", "byte count 6, 3 values need 8"),

    // 6.19 Encapsulated Interface Transport (2B): MEI types other than 0D and 0E
    as_request("6.19", "EncapsulatedInterface_ReservedMeiType", {0x2B, 0x05, 0x01})
        .summary("MEI type 0x05: 01").note("pdu.unknown_function"),

    // 6.20 CANopen General Reference (2B/0D): its data is shown as bytes
    as_request("6.20", "EncapsulatedInterface_CanopenRequestShownRaw",
               {0x2B, 0x0D, 0x00, 0x01, 0x02})
        .function("Encapsulated Interface Transport")
        .summary("CANopen General Reference: 00 01 02"),
    as_response("6.20", "EncapsulatedInterface_CanopenResponseShownRaw", {0x2B, 0x0D, 0x07})
        .summary("CANopen General Reference: 07"),

    // 6.21 Read Device Identification (2B/0E)
    as_request("6.21", "ReadDeviceIdentification_Request", kReadDeviceId)
        .function("Read Device Identification").summary("basic, object 0x00"),
    as_request("6.21", "ReadDeviceIdentification_RequestOneSpecificObject",
               {0x2B, 0x0E, 0x04, 0x05})
        .summary("specific, object 0x05"),
    // Read Device ID codes go from 01 (basic) to 04 (one specific object).
    as_request("6.21", "ReadDeviceIdentification_RequestWithIllegalCode",
               {0x2B, 0x0E, 0x05, 0x00})
        .summary("code 0x05, object 0x00").note("pdu.illegal_value"),
    as_response("6.21", "ReadDeviceIdentification_Response",
                with_objects({0x2B, 0x0E, 0x01, 0x01, 0x00, 0x00, 0x03},
                             {{0x00, "Company"}, {0x01, "PM"}, {0x02, "V2.11"}}),
                kReadDeviceId)
        .function("Read Device Identification")
        .summary("basic, conformity 0x01, more 0x00, next 0x00, 3 objects: "
                 "VendorName=\"Company\", ProductCode=\"PM\", MajorMinorRevision=\"V2.11\""),
    // The other standard object names; a private object (0x80) by its number, with its
    // quote and its byte outside ASCII escaped.
    as_response("6.21", "ReadDeviceIdentification_ObjectNamesAndEscapes",
                {0x2B, 0x0E, 0x03, 0x83, 0xFF, 0x05, 0x05, 0x03, 0x01, 'u', 0x04, 0x01,
                 'p',  0x05, 0x01, 'm',  0x06, 0x01, 'a',  0x80, 0x03, 'a', '"',  0xE9})
        .summary("extended, conformity 0x83, more 0xFF, next 0x05, 5 objects: "
                 "VendorUrl=\"u\", ProductName=\"p\", ModelName=\"m\", "
                 "UserApplicationName=\"a\", object 0x80=\"a\\\"\\xE9\""),
    // Two objects announced, the first 7 bytes long with 4 present.
    as_response("6.21", "ReadDeviceIdentification_ObjectCutShort",
                with_text({0x2B, 0x0E, 0x01, 0x01, 0x00, 0x00, 0x02, 0x00, 0x07}, "Comp"))
        .summary("basic, conformity 0x01, more 0x00, next 0x00, 1 object: "
                 "VendorName=\"Comp\"")
        .note("pdu.malformed", "object 0x00 cut short: 7 bytes announced, 4 present")
        .note("pdu.malformed", "2 objects announced, 1 present"),

    // 7 Exception responses (the function code + 0x80)
    as_response("7", "Exception_SpecExample", {0x81, 0x02}, {0x01, 0x04, 0xA1, 0x00, 0x01})
        .function("Read Coils").exception(0x02)
        .summary("exception 02 Illegal Data Address"),
    as_response("7", "Exception_UnknownCode", {0x90, 0x0C})
        .function("Write Multiple Registers").exception(0x0C)
        .summary("exception 0C unknown exception code").note("pdu.illegal_value"),
    // No code byte: the code reads as 0.
    as_response("7", "Exception_CodeMissing", {0x83})
        .exception(0x00).summary("exception").note("pdu.malformed"),
    as_response("7", "Exception_ExtraBytes", {0x83, 0x02, 0x00})
        .exception(0x02).summary("exception 02 Illegal Data Address").note("pdu.malformed"),
    // One to 2B is named by the request's MEI type when the request is known.
    as_response("7", "Exception_ToReadDeviceIdentification", {0xAB, 0x01}, kReadDeviceId)
        .function("Read Device Identification").exception(0x01)
        .summary("exception 01 Illegal Function"),
    as_response("7", "Exception_ToEncapsulatedInterfaceWithoutRequest", {0xAB, 0x01})
        .function("Encapsulated Interface Transport").exception(0x01)
        .summary("exception 01 Illegal Function"),
};
// clang-format on

class DecoderPdu : public ::testing::TestWithParam<Case> {};

TEST_P(DecoderPdu, DecodesAsItsRowSays) {
    const Case& c = GetParam();
    SCOPED_TRACE(describe(c));
    const DecodedPdu d = decode(c.pdu, c.role, c.asked);

    if (!c.expected_function.empty()) {
        EXPECT_EQ(d.function_name, c.expected_function);
    }
    ASSERT_TRUE(c.expected_summary) << "the row gives no summary";
    EXPECT_EQ(d.summary, *c.expected_summary);
    EXPECT_EQ(d.exception, c.expected_exception.has_value());
    if (c.expected_exception) {
        EXPECT_EQ(d.exception_code, *c.expected_exception);
    }

    Ids expected_ids;
    for (const ExpectedNote& n : c.expected_notes) expected_ids.push_back(n.id);
    EXPECT_EQ(ids(d), expected_ids) << texts(d);
    for (std::size_t i = 0; i < c.expected_notes.size() && i < d.notes.size(); ++i) {
        if (c.expected_notes[i].text) {
            EXPECT_EQ(d.notes[i].text, *c.expected_notes[i].text) << "note " << i;
        }
    }

    if (!c.expected_block) {
        EXPECT_TRUE(d.blocks.empty()) << d.blocks.size() << " blocks, none expected";
        return;
    }
    ASSERT_EQ(d.blocks.size(), 1U);
    const DataBlock& b = d.blocks[0];
    const ExpectedBlock& want = *c.expected_block;
    EXPECT_EQ(table_name(b.table), table_name(want.table));
    EXPECT_EQ(b.start, want.start);
    EXPECT_EQ(b.values, want.values);
    EXPECT_EQ(b.write, want.write);
}

// The row's name, as in DecoderPdu.DecodesAsItsRowSays/ReadCoils_Request.
std::string case_name(const ::testing::TestParamInfo<Case>& param) {
    return param.param.name;
}

INSTANTIATE_TEST_SUITE_P(, DecoderPdu, ::testing::ValuesIn(kCases), case_name);

// ---- Hand-written: loops over many codes, and functions other than decode_pdu() ----

TEST(DecoderDiagnostics, SubFunctionNames) {
    const std::vector<std::pair<std::uint8_t, std::string>> names{
        {0x01, "Restart Communications Option"},
        {0x02, "Return Diagnostic Register"},
        {0x03, "Change ASCII Input Delimiter"},
        {0x04, "Force Listen Only Mode"},
        {0x0A, "Clear Counters and Diagnostic Register"},
        {0x0D, "Return Bus Exception Error Count"},
        {0x0E, "Return Server Message Count"},
        {0x0F, "Return Server No Response Count"},
        {0x10, "Return Server NAK Count"},
        {0x11, "Return Server Busy Count"},
        {0x12, "Return Bus Character Overrun Count"},
        {0x14, "Clear Overrun Counter and Flag"},
    };
    for (const auto& [sub, name] : names) {
        const DecodedPdu d = request({0x08, 0x00, sub, 0x00, 0x00});
        EXPECT_EQ(d.summary, name + " 0x0000");
        EXPECT_TRUE(d.notes.empty()) << name << ": " << texts(d);
    }
}

TEST(DecoderException, AllCodes) {
    const std::vector<std::pair<std::uint8_t, std::string>> codes{
        {0x01, "Illegal Function"},
        {0x02, "Illegal Data Address"},
        {0x03, "Illegal Data Value"},
        {0x04, "Server Device Failure"},
        {0x05, "Acknowledge"},
        {0x06, "Server Device Busy"},
        {0x07, "Negative Acknowledge"},
        {0x08, "Memory Parity Error"},
        {0x0A, "Gateway Path Unavailable"},
        {0x0B, "Gateway Target Device Failed to Respond"},
    };
    for (const auto& [code, name] : codes) {
        ASSERT_NE(exception_name(code), nullptr);
        EXPECT_EQ(exception_name(code), name);
        const DecodedPdu d = response({0x83, code});
        EXPECT_EQ(d.summary, fmt::format("exception {:02X} {}", code, name));
    }
}

// Codes the specification does not define have no name (Exception_UnknownCode above shows
// how such an exception decodes).
TEST(DecoderException, UndefinedCodesHaveNoName) {
    EXPECT_EQ(exception_name(0x09), nullptr);
    EXPECT_EQ(exception_name(0x00), nullptr);
}

// A hex log line or pcap packet can be far longer than Modbus allows: its summary shows
// what a legal frame could hold (252 data bytes, all of a legal frame's) and counts the
// rest, which the frame's hex still shows.
TEST(DecoderUnknownFunction, DataBeyondALegalFrameIsCounted) {
    Bytes pdu{0x41};
    for (std::size_t i = 0; i < kMaxPduDataShown; ++i) pdu.push_back(static_cast<std::uint8_t>(i));
    const std::string whole = request(pdu).summary;
    EXPECT_EQ(whole.size(), 3 * kMaxPduDataShown - 1);
    EXPECT_EQ(whole.substr(whole.size() - 5), "FA FB");
    pdu.resize(pdu.size() + 100'000, 0xEE);
    EXPECT_EQ(request(pdu).summary, whole + " ... (+100000 more)");
}

TEST(DecoderUnknownFunction, Names) {
    EXPECT_EQ(standard_function(0x03).name, "Read Holding Registers");
    EXPECT_EQ(standard_function(0x83).name, "Read Holding Registers");
    EXPECT_EQ(standard_function(0x2B).name, "Encapsulated Interface Transport");
    EXPECT_EQ(standard_function(0x00).name, "Function 0x00");
    EXPECT_EQ(standard_function(0x64).name, "Function 0x64");
    EXPECT_EQ(standard_function(0xC1).name, "Function 0x41");
}

// ---- Truncated and hostile input ----

TEST(DecoderTruncated, FunctionCodeOnly) {
    // Every public code whose layout needs data reports the shortfall in either role.
    for (const std::uint8_t fc : Bytes{0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x08, 0x0F, 0x10, 0x14,
                                       0x15, 0x16, 0x17, 0x18, 0x2B}) {
        EXPECT_EQ(ids(request({fc})), Ids{"pdu.malformed"}) << "request " << int{fc};
        EXPECT_EQ(ids(response({fc})), Ids{"pdu.malformed"}) << "response " << int{fc};
        EXPECT_EQ(request({fc}).summary, "");
    }
    for (const std::uint8_t fc : Bytes{0x07, 0x0B, 0x0C, 0x11}) {
        EXPECT_EQ(ids(request({fc})), Ids{}) << "request " << int{fc};
        EXPECT_EQ(ids(response({fc})), Ids{"pdu.malformed"}) << "response " << int{fc};
    }
}

TEST(DecoderTruncated, EveryPrefixOfEveryExampleDecodesWithoutCrashing) {
    // Each prefix and each role, with and without its request: the decoder must neither
    // crash nor read past the bytes (run under the sanitizers to make the latter visible).
    const std::vector<Bytes> examples{
        kReadCoils,
        kReadHolding,
        kWriteCoils,
        kWriteRegisters,
        kReadFile,
        kReadFileAnswer,
        kWriteFile,
        kReadWrite,
        {0x0C, 0x08, 0x00, 0x00, 0x01, 0x08, 0x01, 0x21, 0x20},
        {0x2B, 0x0E, 0x01, 0x01, 0x00, 0x00, 0x01, 0x00, 0x02, 'a', 'b'},
        {0x18, 0x00, 0x06, 0x00, 0x02, 0x01, 0xB8, 0x12, 0x84}};
    std::size_t notes = 0;
    for (const Bytes& full : examples) {
        for (std::size_t n = 0; n < full.size(); ++n) {
            // A heap copy of exactly n bytes, so reading past it is an error the sanitizer sees.
            const Bytes prefix(full.begin(), full.begin() + static_cast<std::ptrdiff_t>(n));
            for (Role role : {Role::request, Role::response}) {
                notes += decode(prefix, role).notes.size();
                notes += decode(prefix, role, full).notes.size();
                notes += decode(full, role, prefix).notes.size();
            }
        }
    }
    EXPECT_GT(notes, 0U);
}

TEST(DecoderTruncated, EveryFunctionCodeWithPatternedData) {
    for (unsigned fc = 0; fc < 256; ++fc) {
        for (const std::uint8_t fill : Bytes{0x00, 0x01, 0x07, 0xFF}) {
            for (std::size_t n = 0; n < 12; ++n) {
                Bytes pdu{static_cast<std::uint8_t>(fc)};
                pdu.insert(pdu.end(), n, fill);
                const DecodedPdu q = decode(pdu, Role::request);
                const DecodedPdu a = decode(pdu, Role::response, pdu);
                EXPECT_FALSE(q.function_name.empty());
                EXPECT_FALSE(a.function_name.empty());
            }
        }
    }
}

}  // namespace
}  // namespace rtuscope
