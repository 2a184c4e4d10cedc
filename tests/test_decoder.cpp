// Decoder tests. The PDUs are the examples of the MODBUS Application Protocol
// Specification V1.1b3 (section numbers given per test), plus broken variants of them.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <string_view>
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

Bytes with_text(Bytes head, std::string_view text) {
    head.insert(head.end(), text.begin(), text.end());
    return head;
}

void expect_block(const DecodedPdu& d, DataTable table, std::uint16_t start,
                  const std::vector<std::uint16_t>& values, bool write) {
    ASSERT_EQ(d.blocks.size(), 1U);
    EXPECT_EQ(d.blocks[0].table, table);
    EXPECT_EQ(d.blocks[0].start, start);
    EXPECT_EQ(d.blocks[0].values, values);
    EXPECT_EQ(d.blocks[0].write, write);
}

// ---- 6.1 Read Coils (01) ----

const Bytes kReadCoils{0x01, 0x00, 0x13, 0x00, 0x13};

TEST(DecoderReadCoils, Request) {
    const DecodedPdu d = request(kReadCoils);
    EXPECT_EQ(d.function_name, "Read Coils");
    EXPECT_EQ(d.summary, "0x0013 x19");
    EXPECT_FALSE(d.exception);
    EXPECT_TRUE(d.notes.empty()) << texts(d);
    EXPECT_TRUE(d.blocks.empty());
}

TEST(DecoderReadCoils, ResponseWithRequestShowsExactlyTheQuantity) {
    const DecodedPdu d = response({0x01, 0x03, 0xCD, 0x6B, 0x05}, kReadCoils);
    EXPECT_EQ(d.summary, "19 coils: 1011001111010110101");
    EXPECT_TRUE(d.notes.empty()) << texts(d);
    expect_block(d, DataTable::coils, 0x0013,
                 {1, 0, 1, 1, 0, 0, 1, 1, 1, 1, 0, 1, 0, 1, 1, 0, 1, 0, 1}, false);
}

TEST(DecoderReadCoils, ResponseWithoutRequestShowsEveryBitAndNoBlock) {
    const DecodedPdu d = response({0x01, 0x03, 0xCD, 0x6B, 0x05});
    EXPECT_EQ(d.summary, "24 coils: 101100111101011010100000");
    EXPECT_TRUE(d.notes.empty()) << texts(d);
    EXPECT_TRUE(d.blocks.empty());
}

TEST(DecoderReadCoils, ByteCountDisagreesWithRequest) {
    const DecodedPdu d = response({0x01, 0x02, 0xCD, 0x6B}, kReadCoils);
    EXPECT_EQ(ids(d), Ids{"pdu.byte_count_mismatch"});
    EXPECT_EQ(d.notes[0].text, "byte count 2, 19 coils asked need 3");
    EXPECT_EQ(d.summary, "16 coils: 1011001111010110");
}

TEST(DecoderReadCoils, QuantityLimits) {
    EXPECT_EQ(ids(request({0x01, 0x00, 0x00, 0x07, 0xD0})), Ids{});  // 2000
    const DecodedPdu d = request({0x01, 0x00, 0x00, 0x07, 0xD1});    // 2001
    EXPECT_EQ(ids(d), Ids{"pdu.illegal_value"});
    EXPECT_EQ(d.notes[0].text, "quantity 2001 out of range 1..2000");
}

TEST(DecoderReadCoils, LongListIsCutInTheSummaryButNotInTheBlock) {
    Bytes pdu{0x01, 0x0A};
    pdu.insert(pdu.end(), 10, 0xFF);
    const DecodedPdu d = response(pdu, {0x01, 0x00, 0x00, 0x00, 0x50});
    EXPECT_EQ(d.summary, "80 coils: " + std::string(64, '1') + " ... (+16 more)");
    EXPECT_TRUE(d.notes.empty()) << texts(d);  // 80 coils fill exactly 10 bytes
    ASSERT_EQ(d.blocks.size(), 1U);
    EXPECT_EQ(d.blocks[0].values.size(), 80U);
}

// ---- 6.2 Read Discrete Inputs (02) ----

const Bytes kReadInputs{0x02, 0x00, 0xC4, 0x00, 0x16};

TEST(DecoderReadDiscreteInputs, Request) {
    const DecodedPdu d = request(kReadInputs);
    EXPECT_EQ(d.function_name, "Read Discrete Inputs");
    EXPECT_EQ(d.summary, "0x00C4 x22");
    EXPECT_TRUE(d.notes.empty()) << texts(d);
}

TEST(DecoderReadDiscreteInputs, Response) {
    const DecodedPdu d = response({0x02, 0x03, 0xAC, 0xDB, 0x35}, kReadInputs);
    EXPECT_EQ(d.summary, "22 inputs: 0011010111011011101011");
    EXPECT_TRUE(d.notes.empty()) << texts(d);
    ASSERT_EQ(d.blocks.size(), 1U);
    EXPECT_EQ(d.blocks[0].table, DataTable::discrete_inputs);
    EXPECT_EQ(d.blocks[0].start, 0x00C4);
    EXPECT_EQ(d.blocks[0].values.size(), 22U);
    EXPECT_FALSE(d.blocks[0].write);
}

// ---- 6.3 Read Holding Registers (03) ----

const Bytes kReadHolding{0x03, 0x00, 0x6B, 0x00, 0x03};

TEST(DecoderReadHoldingRegisters, Request) {
    const DecodedPdu d = request(kReadHolding);
    EXPECT_EQ(d.function_name, "Read Holding Registers");
    EXPECT_EQ(d.summary, "0x006B x3");
    EXPECT_TRUE(d.notes.empty()) << texts(d);
}

TEST(DecoderReadHoldingRegisters, Response) {
    const DecodedPdu d = response({0x03, 0x06, 0x02, 0x2B, 0x00, 0x00, 0x00, 0x64}, kReadHolding);
    EXPECT_EQ(d.summary, "3 registers: 0x022B 0x0000 0x0064");
    EXPECT_TRUE(d.notes.empty()) << texts(d);
    expect_block(d, DataTable::holding_registers, 0x006B, {0x022B, 0x0000, 0x0064}, false);
}

TEST(DecoderReadHoldingRegisters, ResponseWithoutRequestHasNoBlock) {
    const DecodedPdu d = response({0x03, 0x04, 0x18, 0x18, 0x00, 0x00});
    EXPECT_EQ(d.summary, "2 registers: 0x1818 0x0000");
    EXPECT_TRUE(d.notes.empty()) << texts(d);
    EXPECT_TRUE(d.blocks.empty());
}

TEST(DecoderReadHoldingRegisters, AnswerShorterThanAsked) {
    const DecodedPdu d = response({0x03, 0x02, 0x18, 0x18}, {0x03, 0x00, 0x00, 0x00, 0x02});
    EXPECT_EQ(d.summary, "1 register: 0x1818");
    EXPECT_EQ(ids(d), Ids{"pdu.byte_count_mismatch"});
    EXPECT_EQ(d.notes[0].text, "byte count 2, 2 registers asked need 4");
    expect_block(d, DataTable::holding_registers, 0x0000, {0x1818}, false);
}

TEST(DecoderReadHoldingRegisters, ByteCountDisagreesWithDataPresent) {
    const DecodedPdu d = response({0x03, 0x06, 0x00, 0x01, 0x00, 0x02});
    EXPECT_EQ(ids(d), Ids{"pdu.byte_count_mismatch"});
    EXPECT_EQ(d.notes[0].text, "byte count 6, 4 bytes present");
    EXPECT_EQ(d.summary, "2 registers: 0x0001 0x0002");
}

TEST(DecoderReadHoldingRegisters, OddByteCount) {
    const DecodedPdu d = response({0x03, 0x03, 0x00, 0x01, 0x02});
    EXPECT_EQ(ids(d), Ids{"pdu.malformed"});
    EXPECT_EQ(d.summary, "1 register: 0x0001");
}

TEST(DecoderReadHoldingRegisters, QuantityOutOfRange) {
    const DecodedPdu zero = request({0x03, 0x00, 0x00, 0x00, 0x00});
    EXPECT_EQ(ids(zero), Ids{"pdu.illegal_value"});
    EXPECT_EQ(zero.notes[0].text, "quantity 0 out of range 1..125");
    EXPECT_EQ(ids(request({0x03, 0x00, 0x00, 0x00, 0x7D})), Ids{});
    EXPECT_EQ(ids(request({0x03, 0x00, 0x00, 0x00, 0x7E})), Ids{"pdu.illegal_value"});
}

TEST(DecoderReadHoldingRegisters, RangePastTheLastAddress) {
    const DecodedPdu d = request({0x03, 0xFF, 0xFF, 0x00, 0x02});
    EXPECT_EQ(ids(d), Ids{"pdu.illegal_value"});
    EXPECT_EQ(d.notes[0].text, "0xFFFF x2 runs past address 0xFFFF");
}

TEST(DecoderReadHoldingRegisters, RequestTooLongOrShort) {
    const DecodedPdu longer = request({0x03, 0x00, 0x00, 0x00, 0x02, 0x00});
    EXPECT_EQ(longer.summary, "0x0000 x2");
    EXPECT_EQ(ids(longer), Ids{"pdu.malformed"});
    EXPECT_EQ(longer.notes[0].text, "PDU too long: 5 bytes expected, 6 present");

    const DecodedPdu shorter = request({0x03, 0x00, 0x10, 0x00});
    EXPECT_EQ(shorter.summary, "0x0010");
    EXPECT_EQ(ids(shorter), Ids{"pdu.malformed"});
    EXPECT_EQ(shorter.notes[0].text, "PDU too short: 5 bytes expected, 4 present");
}

TEST(DecoderReadHoldingRegisters, LongListIsCut) {
    Bytes pdu{0x03, 20};
    for (std::uint8_t i = 0; i < 10; ++i) {
        pdu.push_back(0);
        pdu.push_back(i);
    }
    const DecodedPdu d = response(pdu, {0x03, 0x00, 0x00, 0x00, 0x0A});
    EXPECT_EQ(d.summary,
              "10 registers: 0x0000 0x0001 0x0002 0x0003 0x0004 0x0005 0x0006 0x0007 ... (+2 "
              "more)");
    ASSERT_EQ(d.blocks.size(), 1U);
    EXPECT_EQ(d.blocks[0].values.size(), 10U);
}

TEST(DecoderReadHoldingRegisters, AnswerToAnotherFunction) {
    const DecodedPdu d = response({0x03, 0x02, 0x00, 0x01}, {0x04, 0x00, 0x00, 0x00, 0x01});
    EXPECT_EQ(ids(d), Ids{"pdu.request_mismatch"});
    EXPECT_EQ(d.summary, "1 register: 0x0001");
    EXPECT_TRUE(d.blocks.empty());  // the request's start address does not apply
}

// ---- 6.4 Read Input Registers (04) ----

TEST(DecoderReadInputRegisters, RequestAndResponse) {
    const Bytes asked{0x04, 0x00, 0x08, 0x00, 0x01};
    const DecodedPdu q = request(asked);
    EXPECT_EQ(q.function_name, "Read Input Registers");
    EXPECT_EQ(q.summary, "0x0008 x1");
    const DecodedPdu a = response({0x04, 0x02, 0x00, 0x0A}, asked);
    EXPECT_EQ(a.summary, "1 register: 0x000A");
    EXPECT_TRUE(a.notes.empty()) << texts(a);
    expect_block(a, DataTable::input_registers, 0x0008, {0x000A}, false);
}

// ---- 6.5 Write Single Coil (05) ----

const Bytes kWriteCoil{0x05, 0x00, 0xAC, 0xFF, 0x00};

TEST(DecoderWriteSingleCoil, RequestOn) {
    const DecodedPdu d = request(kWriteCoil);
    EXPECT_EQ(d.function_name, "Write Single Coil");
    EXPECT_EQ(d.summary, "0x00AC ON");
    EXPECT_TRUE(d.notes.empty()) << texts(d);
    expect_block(d, DataTable::coils, 0x00AC, {1}, true);
}

TEST(DecoderWriteSingleCoil, EchoOff) {
    const Bytes off{0x05, 0x00, 0xAC, 0x00, 0x00};
    const DecodedPdu d = response(off, off);
    EXPECT_EQ(d.summary, "0x00AC OFF");
    EXPECT_TRUE(d.notes.empty()) << texts(d);
    expect_block(d, DataTable::coils, 0x00AC, {0}, true);
}

TEST(DecoderWriteSingleCoil, EchoDiffersFromRequest) {
    const DecodedPdu d = response({0x05, 0x00, 0xAC, 0x00, 0x00}, kWriteCoil);
    EXPECT_EQ(ids(d), Ids{"pdu.request_mismatch"});
    EXPECT_EQ(d.notes[0].text, "request was 0x00AC ON");
}

TEST(DecoderWriteSingleCoil, IllegalValue) {
    const DecodedPdu d = request({0x05, 0x00, 0xAC, 0x12, 0x34});
    EXPECT_EQ(d.summary, "0x00AC 0x1234");
    EXPECT_EQ(ids(d), Ids{"pdu.illegal_value"});
    EXPECT_TRUE(d.blocks.empty());
}

// ---- 6.6 Write Single Register (06) ----

TEST(DecoderWriteSingleRegister, RequestAndEcho) {
    const Bytes pdu{0x06, 0x00, 0x01, 0x00, 0x03};
    const DecodedPdu q = request(pdu);
    EXPECT_EQ(q.function_name, "Write Single Register");
    EXPECT_EQ(q.summary, "0x0001 = 0x0003 (3)");
    expect_block(q, DataTable::holding_registers, 0x0001, {0x0003}, true);
    const DecodedPdu a = response(pdu, pdu);
    EXPECT_EQ(a.summary, "0x0001 = 0x0003 (3)");
    EXPECT_TRUE(a.notes.empty()) << texts(a);
    expect_block(a, DataTable::holding_registers, 0x0001, {0x0003}, true);
}

TEST(DecoderWriteSingleRegister, EchoToAnotherAddress) {
    const DecodedPdu d = response({0x06, 0x00, 0x02, 0x00, 0x03}, {0x06, 0x00, 0x01, 0x00, 0x03});
    EXPECT_EQ(ids(d), Ids{"pdu.request_mismatch"});
    EXPECT_EQ(d.notes[0].text, "request was 0x0001 = 0x0003 (3)");
}

// ---- 6.7 Read Exception Status (07) ----

TEST(DecoderReadExceptionStatus, RequestAndResponse) {
    const DecodedPdu q = request({0x07});
    EXPECT_EQ(q.function_name, "Read Exception Status");
    EXPECT_EQ(q.summary, "");
    EXPECT_TRUE(q.notes.empty()) << texts(q);
    const DecodedPdu a = response({0x07, 0x6D}, {0x07});
    EXPECT_EQ(a.summary, "status 0x6D");
    EXPECT_TRUE(a.notes.empty()) << texts(a);
    EXPECT_EQ(ids(request({0x07, 0x00})), Ids{"pdu.malformed"});
}

// ---- 6.8 Diagnostics (08) ----

TEST(DecoderDiagnostics, ReturnQueryDataEcho) {
    const Bytes pdu{0x08, 0x00, 0x00, 0xA5, 0x37};
    const DecodedPdu q = request(pdu);
    EXPECT_EQ(q.function_name, "Diagnostics");
    EXPECT_EQ(q.summary, "Return Query Data 0xA537");
    EXPECT_TRUE(q.notes.empty()) << texts(q);
    const DecodedPdu a = response(pdu, pdu);
    EXPECT_EQ(a.summary, "Return Query Data 0xA537");
    EXPECT_TRUE(a.notes.empty()) << texts(a);
}

TEST(DecoderDiagnostics, ReturnQueryDataAnyLength) {
    const DecodedPdu d = request({0x08, 0x00, 0x00, 0x01, 0x02, 0x03});
    EXPECT_EQ(d.summary, "Return Query Data 01 02 03");
    EXPECT_TRUE(d.notes.empty()) << texts(d);
}

TEST(DecoderDiagnostics, ReturnQueryDataEchoDiffers) {
    const DecodedPdu d = response({0x08, 0x00, 0x00, 0xA5, 0x38}, {0x08, 0x00, 0x00, 0xA5, 0x37});
    EXPECT_EQ(ids(d), Ids{"pdu.request_mismatch"});
}

TEST(DecoderDiagnostics, Counters) {
    const Bytes asked{0x08, 0x00, 0x0B, 0x00, 0x00};
    EXPECT_EQ(request(asked).summary, "Return Bus Message Count 0x0000");
    const DecodedPdu a = response({0x08, 0x00, 0x0B, 0x01, 0x08}, asked);
    EXPECT_EQ(a.summary, "Return Bus Message Count 0x0108");
    EXPECT_TRUE(a.notes.empty()) << texts(a);
    const DecodedPdu other = response({0x08, 0x00, 0x0C, 0x00, 0x01}, asked);
    EXPECT_EQ(other.summary, "Return Bus Communication Error Count 0x0001");
    EXPECT_EQ(ids(other), Ids{"pdu.request_mismatch"});
}

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

TEST(DecoderDiagnostics, IllegalRequestData) {
    EXPECT_EQ(ids(request({0x08, 0x00, 0x01, 0xFF, 0x00})), Ids{});
    EXPECT_EQ(ids(request({0x08, 0x00, 0x01, 0x12, 0x34})), Ids{"pdu.illegal_value"});
    EXPECT_EQ(ids(request({0x08, 0x00, 0x03, 0x0A, 0x00})), Ids{});
    EXPECT_EQ(ids(request({0x08, 0x00, 0x03, 0x0A, 0x01})), Ids{"pdu.illegal_value"});
    EXPECT_EQ(ids(request({0x08, 0x00, 0x0B, 0x00, 0x01})), Ids{"pdu.illegal_value"});
    EXPECT_EQ(ids(request({0x08, 0x00, 0x0B, 0x00})), Ids{"pdu.malformed"});
}

TEST(DecoderDiagnostics, ReservedSubFunction) {
    const DecodedPdu d = request({0x08, 0x00, 0x05, 0x00, 0x00});
    EXPECT_EQ(d.summary, "sub-function 0x0005 0x0000");
    EXPECT_EQ(ids(d), Ids{"pdu.unknown_function"});
}

// ---- 6.9 Get Comm Event Counter (0B) ----

TEST(DecoderGetCommEventCounter, RequestAndResponse) {
    const DecodedPdu q = request({0x0B});
    EXPECT_EQ(q.function_name, "Get Comm Event Counter");
    EXPECT_EQ(q.summary, "");
    EXPECT_TRUE(q.notes.empty()) << texts(q);
    const DecodedPdu a = response({0x0B, 0xFF, 0xFF, 0x01, 0x08}, {0x0B});
    EXPECT_EQ(a.summary, "status 0xFFFF, event count 264");
    EXPECT_TRUE(a.notes.empty()) << texts(a);
}

TEST(DecoderGetCommEventCounter, ShortResponse) {
    const DecodedPdu d = response({0x0B, 0x00, 0x00, 0x01});
    EXPECT_EQ(d.summary, "status 0x0000");
    EXPECT_EQ(ids(d), Ids{"pdu.malformed"});
}

// ---- 6.10 Get Comm Event Log (0C) ----

TEST(DecoderGetCommEventLog, RequestAndResponse) {
    const DecodedPdu q = request({0x0C});
    EXPECT_EQ(q.function_name, "Get Comm Event Log");
    EXPECT_TRUE(q.notes.empty()) << texts(q);
    const DecodedPdu a =
        response({0x0C, 0x08, 0x00, 0x00, 0x01, 0x08, 0x01, 0x21, 0x20, 0x00}, {0x0C});
    EXPECT_EQ(a.summary, "status 0x0000, event count 264, message count 289, 2 events: 20 00");
    EXPECT_TRUE(a.notes.empty()) << texts(a);
}

TEST(DecoderGetCommEventLog, ByteCountTooSmall) {
    const DecodedPdu d = response({0x0C, 0x02, 0x00, 0x00});
    EXPECT_EQ(d.summary, "status 0x0000");
    EXPECT_EQ(ids(d), Ids{"pdu.malformed"});
}

// ---- 6.11 Write Multiple Coils (0F) ----

const Bytes kWriteCoils{0x0F, 0x00, 0x13, 0x00, 0x0A, 0x02, 0xCD, 0x01};

TEST(DecoderWriteMultipleCoils, Request) {
    const DecodedPdu d = request(kWriteCoils);
    EXPECT_EQ(d.function_name, "Write Multiple Coils");
    EXPECT_EQ(d.summary, "0x0013 x10: 1011001110");
    EXPECT_TRUE(d.notes.empty()) << texts(d);
    expect_block(d, DataTable::coils, 0x0013, {1, 0, 1, 1, 0, 0, 1, 1, 1, 0}, true);
}

TEST(DecoderWriteMultipleCoils, Response) {
    const DecodedPdu d = response({0x0F, 0x00, 0x13, 0x00, 0x0A}, kWriteCoils);
    EXPECT_EQ(d.summary, "0x0013 x10");
    EXPECT_TRUE(d.notes.empty()) << texts(d);
    EXPECT_TRUE(d.blocks.empty());
}

TEST(DecoderWriteMultipleCoils, ResponseQuantityDiffers) {
    const DecodedPdu d = response({0x0F, 0x00, 0x13, 0x00, 0x09}, kWriteCoils);
    EXPECT_EQ(ids(d), Ids{"pdu.request_mismatch"});
    EXPECT_EQ(d.notes[0].text, "request was 0x0013 x10");
}

TEST(DecoderWriteMultipleCoils, ByteCountDisagreesWithQuantity) {
    const DecodedPdu d = request({0x0F, 0x00, 0x13, 0x00, 0x0A, 0x01, 0xCD});
    EXPECT_EQ(ids(d), Ids{"pdu.byte_count_mismatch"});
    EXPECT_EQ(d.notes[0].text, "byte count 1, 10 coils need 2");
    EXPECT_EQ(d.summary, "0x0013 x10: 10110011");
}

TEST(DecoderWriteMultipleCoils, QuantityLimit) {
    // 1969 coils need 247 bytes: the byte count agrees, only the quantity is illegal.
    Bytes pdu{0x0F, 0x00, 0x00, 0x07, 0xB1, 247};
    pdu.insert(pdu.end(), 247, 0x00);
    EXPECT_EQ(ids(request(pdu)), Ids{"pdu.illegal_value"});
}

// ---- 6.12 Write Multiple Registers (10) ----

const Bytes kWriteRegisters{0x10, 0x00, 0x01, 0x00, 0x02, 0x04, 0x00, 0x0A, 0x01, 0x02};

TEST(DecoderWriteMultipleRegisters, Request) {
    const DecodedPdu d = request(kWriteRegisters);
    EXPECT_EQ(d.function_name, "Write Multiple Registers");
    EXPECT_EQ(d.summary, "0x0001 x2: 0x000A 0x0102");
    EXPECT_TRUE(d.notes.empty()) << texts(d);
    expect_block(d, DataTable::holding_registers, 0x0001, {0x000A, 0x0102}, true);
}

TEST(DecoderWriteMultipleRegisters, Response) {
    const DecodedPdu d = response({0x10, 0x00, 0x01, 0x00, 0x02}, kWriteRegisters);
    EXPECT_EQ(d.summary, "0x0001 x2");
    EXPECT_TRUE(d.notes.empty()) << texts(d);
    EXPECT_TRUE(d.blocks.empty());
}

TEST(DecoderWriteMultipleRegisters, ByteCountAndDataDisagree) {
    const DecodedPdu d = request({0x10, 0x00, 0x01, 0x00, 0x02, 0x04, 0x00, 0x0A});
    EXPECT_EQ(ids(d), Ids{"pdu.byte_count_mismatch"});
    EXPECT_EQ(d.notes[0].text, "byte count 4, 2 bytes present");
    expect_block(d, DataTable::holding_registers, 0x0001, {0x000A}, true);
}

TEST(DecoderWriteMultipleRegisters, QuantityLimit) {
    Bytes pdu{0x10, 0x00, 0x00, 0x00, 0x7C, 248};
    pdu.insert(pdu.end(), 248, 0x00);
    const DecodedPdu d = request(pdu);
    EXPECT_EQ(ids(d), Ids{"pdu.illegal_value"});
    EXPECT_EQ(d.notes[0].text, "quantity 124 out of range 1..123");
}

// ---- 6.13 Report Server ID (11) ----

TEST(DecoderReportServerId, RequestAndResponse) {
    const DecodedPdu q = request({0x11});
    EXPECT_EQ(q.function_name, "Report Server ID");
    EXPECT_EQ(q.summary, "");
    EXPECT_TRUE(q.notes.empty()) << texts(q);
    const DecodedPdu a = response({0x11, 0x03, 0x01, 0x02, 0xFF}, {0x11});
    EXPECT_EQ(a.summary, "3 bytes: 01 02 FF");
    EXPECT_TRUE(a.notes.empty()) << texts(a);
}

// ---- 6.14 Read File Record (14) ----

const Bytes kReadFile{0x14, 0x0E, 0x06, 0x00, 0x04, 0x00, 0x01, 0x00,
                      0x02, 0x06, 0x00, 0x03, 0x00, 0x09, 0x00, 0x02};
const Bytes kReadFileAnswer{0x14, 0x0C, 0x05, 0x06, 0x0D, 0xFE, 0x00,
                            0x20, 0x05, 0x06, 0x33, 0xCD, 0x00, 0x40};

TEST(DecoderReadFileRecord, Request) {
    const DecodedPdu d = request(kReadFile);
    EXPECT_EQ(d.function_name, "Read File Record");
    EXPECT_EQ(d.summary, "2 sub-requests: file 4 record 0x0001 x2, file 3 record 0x0009 x2");
    EXPECT_TRUE(d.notes.empty()) << texts(d);
}

TEST(DecoderReadFileRecord, ResponseWithRequest) {
    const DecodedPdu d = response(kReadFileAnswer, kReadFile);
    EXPECT_EQ(d.summary,
              "2 sub-responses: file 4 record 0x0001 x2: 0x0DFE 0x0020, file 3 record 0x0009 x2: "
              "0x33CD 0x0040");
    EXPECT_TRUE(d.notes.empty()) << texts(d);
}

TEST(DecoderReadFileRecord, ResponseWithoutRequest) {
    const DecodedPdu d = response(kReadFileAnswer);
    EXPECT_EQ(d.summary, "2 sub-responses: 0x0DFE 0x0020, 0x33CD 0x0040");
    EXPECT_TRUE(d.notes.empty()) << texts(d);
}

TEST(DecoderReadFileRecord, FewerSubResponsesThanAsked) {
    const DecodedPdu d = response({0x14, 0x06, 0x05, 0x06, 0x0D, 0xFE, 0x00, 0x20}, kReadFile);
    EXPECT_EQ(ids(d), Ids{"pdu.request_mismatch"});
    EXPECT_EQ(d.notes[0].text, "1 sub-response, 2 asked");
}

TEST(DecoderReadFileRecord, BadReferenceTypeAndRecordNumber) {
    const DecodedPdu d = request({0x14, 0x07, 0x05, 0x00, 0x04, 0x27, 0x10, 0x00, 0x02});
    EXPECT_EQ(ids(d), (Ids{"pdu.illegal_value", "pdu.illegal_value"}));
}

// ---- 6.15 Write File Record (15) ----

const Bytes kWriteFile{0x15, 0x0D, 0x06, 0x00, 0x04, 0x00, 0x07, 0x00,
                       0x03, 0x06, 0xAF, 0x04, 0xBE, 0x10, 0x0D};

TEST(DecoderWriteFileRecord, RequestAndEcho) {
    const DecodedPdu q = request(kWriteFile);
    EXPECT_EQ(q.function_name, "Write File Record");
    EXPECT_EQ(q.summary, "1 sub-request: file 4 record 0x0007 x3: 0x06AF 0x04BE 0x100D");
    EXPECT_TRUE(q.notes.empty()) << texts(q);
    const DecodedPdu a = response(kWriteFile, kWriteFile);
    EXPECT_EQ(a.summary, q.summary);
    EXPECT_TRUE(a.notes.empty()) << texts(a);
}

TEST(DecoderWriteFileRecord, EchoDiffers) {
    Bytes echo = kWriteFile;
    echo.back() = 0x0E;
    EXPECT_EQ(ids(response(echo, kWriteFile)), Ids{"pdu.request_mismatch"});
}

TEST(DecoderWriteFileRecord, RecordDataCutShort) {
    const DecodedPdu d =
        request({0x15, 0x0B, 0x06, 0x00, 0x04, 0x00, 0x07, 0x00, 0x03, 0x06, 0xAF, 0x04, 0xBE});
    EXPECT_EQ(ids(d), Ids{"pdu.malformed"});
    EXPECT_EQ(d.summary, "1 sub-request: file 4 record 0x0007 x3: 0x06AF 0x04BE");
}

// ---- 6.16 Mask Write Register (16) ----

TEST(DecoderMaskWriteRegister, RequestAndEcho) {
    const Bytes pdu{0x16, 0x00, 0x04, 0x00, 0xF2, 0x00, 0x25};
    const DecodedPdu q = request(pdu);
    EXPECT_EQ(q.function_name, "Mask Write Register");
    EXPECT_EQ(q.summary, "0x0004 AND 0x00F2 OR 0x0025");
    EXPECT_TRUE(q.notes.empty()) << texts(q);
    const DecodedPdu a = response(pdu, pdu);
    EXPECT_EQ(a.summary, "0x0004 AND 0x00F2 OR 0x0025");
    EXPECT_TRUE(a.notes.empty()) << texts(a);
    const DecodedPdu other = response({0x16, 0x00, 0x04, 0x00, 0xF2, 0x00, 0x26}, pdu);
    EXPECT_EQ(ids(other), Ids{"pdu.request_mismatch"});
}

// ---- 6.17 Read/Write Multiple Registers (17) ----

const Bytes kReadWrite{0x17, 0x00, 0x03, 0x00, 0x06, 0x00, 0x0E, 0x00,
                       0x03, 0x06, 0x00, 0xFF, 0x00, 0xFF, 0x00, 0xFF};

TEST(DecoderReadWriteMultipleRegisters, Request) {
    const DecodedPdu d = request(kReadWrite);
    EXPECT_EQ(d.function_name, "Read/Write Multiple Registers");
    EXPECT_EQ(d.summary, "read 0x0003 x6, write 0x000E x3: 0x00FF 0x00FF 0x00FF");
    EXPECT_TRUE(d.notes.empty()) << texts(d);
    expect_block(d, DataTable::holding_registers, 0x000E, {0x00FF, 0x00FF, 0x00FF}, true);
}

TEST(DecoderReadWriteMultipleRegisters, Response) {
    const DecodedPdu d = response(
        {0x17, 0x0C, 0x00, 0xFE, 0x0A, 0xCD, 0x00, 0x01, 0x00, 0x03, 0x00, 0x0D, 0x00, 0xFF},
        kReadWrite);
    EXPECT_EQ(d.summary, "6 registers: 0x00FE 0x0ACD 0x0001 0x0003 0x000D 0x00FF");
    EXPECT_TRUE(d.notes.empty()) << texts(d);
    expect_block(d, DataTable::holding_registers, 0x0003,
                 {0x00FE, 0x0ACD, 0x0001, 0x0003, 0x000D, 0x00FF}, false);
}

TEST(DecoderReadWriteMultipleRegisters, WriteQuantityLimit) {
    Bytes pdu{0x17, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x7A, 244};
    pdu.insert(pdu.end(), 244, 0x00);
    const DecodedPdu d = request(pdu);
    EXPECT_EQ(ids(d), Ids{"pdu.illegal_value"});
    EXPECT_EQ(d.notes[0].text, "write quantity 122 out of range 1..121");
}

// ---- 6.18 Read FIFO Queue (18) ----

TEST(DecoderReadFifoQueue, RequestAndResponse) {
    const DecodedPdu q = request({0x18, 0x04, 0xDE});
    EXPECT_EQ(q.function_name, "Read FIFO Queue");
    EXPECT_EQ(q.summary, "FIFO 0x04DE");
    EXPECT_TRUE(q.notes.empty()) << texts(q);
    const DecodedPdu a =
        response({0x18, 0x00, 0x06, 0x00, 0x02, 0x01, 0xB8, 0x12, 0x84}, {0x18, 0x04, 0xDE});
    EXPECT_EQ(a.summary, "2 values: 0x01B8 0x1284");
    EXPECT_TRUE(a.notes.empty()) << texts(a);
}

TEST(DecoderReadFifoQueue, CountDisagreesWithByteCount) {
    const DecodedPdu d = response({0x18, 0x00, 0x06, 0x00, 0x03, 0x01, 0xB8, 0x12, 0x84});
    EXPECT_EQ(ids(d), Ids{"pdu.byte_count_mismatch"});
    EXPECT_EQ(d.notes[0].text, "byte count 6, 3 values need 8");
}

// ---- 6.19 / 6.21 Encapsulated Interface Transport, Read Device Identification (2B/0E) ----

TEST(DecoderReadDeviceIdentification, Request) {
    const DecodedPdu d = request({0x2B, 0x0E, 0x01, 0x00});
    EXPECT_EQ(d.function_name, "Read Device Identification");
    EXPECT_EQ(d.summary, "basic, object 0x00");
    EXPECT_TRUE(d.notes.empty()) << texts(d);
    EXPECT_EQ(request({0x2B, 0x0E, 0x04, 0x05}).summary, "specific, object 0x05");
    EXPECT_EQ(ids(request({0x2B, 0x0E, 0x05, 0x00})), Ids{"pdu.illegal_value"});
}

TEST(DecoderReadDeviceIdentification, Response) {
    Bytes pdu = with_text({0x2B, 0x0E, 0x01, 0x01, 0x00, 0x00, 0x03, 0x00, 0x07}, "Company");
    pdu = with_text(pdu, std::string_view("\x01\x02", 2));
    pdu = with_text(pdu, "PM");
    pdu = with_text(pdu, std::string_view("\x02\x05", 2));
    pdu = with_text(pdu, "V2.11");
    const DecodedPdu d = response(pdu, {0x2B, 0x0E, 0x01, 0x00});
    EXPECT_EQ(d.function_name, "Read Device Identification");
    EXPECT_EQ(d.summary,
              "basic, conformity 0x01, more 0x00, next 0x00, 3 objects: VendorName=\"Company\", "
              "ProductCode=\"PM\", MajorMinorRevision=\"V2.11\"");
    EXPECT_TRUE(d.notes.empty()) << texts(d);
}

TEST(DecoderReadDeviceIdentification, ObjectNamesAndEscapes) {
    const Bytes pdu{0x2B, 0x0E, 0x03, 0x83, 0xFF, 0x05, 0x05, 0x03, 0x01, 'u', 0x04, 0x01,
                    'p',  0x05, 0x01, 'm',  0x06, 0x01, 'a',  0x80, 0x03, 'a', '"',  0xE9};
    const DecodedPdu d = response(pdu);
    EXPECT_EQ(d.summary,
              "extended, conformity 0x83, more 0xFF, next 0x05, 5 objects: VendorUrl=\"u\", "
              "ProductName=\"p\", ModelName=\"m\", UserApplicationName=\"a\", "
              "object 0x80=\"a\\\"\\xE9\"");
    EXPECT_TRUE(d.notes.empty()) << texts(d);
}

TEST(DecoderReadDeviceIdentification, ObjectCutShort) {
    const DecodedPdu d =
        response(with_text({0x2B, 0x0E, 0x01, 0x01, 0x00, 0x00, 0x02, 0x00, 0x07}, "Comp"));
    EXPECT_EQ(d.summary,
              "basic, conformity 0x01, more 0x00, next 0x00, 1 object: VendorName=\"Comp\"");
    EXPECT_EQ(ids(d), (Ids{"pdu.malformed", "pdu.malformed"}));
}

TEST(DecoderEncapsulatedInterface, CanopenShownRaw) {
    const DecodedPdu d = request({0x2B, 0x0D, 0x00, 0x01, 0x02});
    EXPECT_EQ(d.function_name, "Encapsulated Interface Transport");
    EXPECT_EQ(d.summary, "CANopen General Reference: 00 01 02");
    EXPECT_TRUE(d.notes.empty()) << texts(d);
    const DecodedPdu a = response({0x2B, 0x0D, 0x07});
    EXPECT_EQ(a.summary, "CANopen General Reference: 07");
}

TEST(DecoderEncapsulatedInterface, ReservedMeiType) {
    const DecodedPdu d = request({0x2B, 0x05, 0x01});
    EXPECT_EQ(d.summary, "MEI type 0x05: 01");
    EXPECT_EQ(ids(d), Ids{"pdu.unknown_function"});
}

// ---- Section 7: exception responses ----

TEST(DecoderException, SpecExample) {
    const DecodedPdu d = response({0x81, 0x02}, {0x01, 0x04, 0xA1, 0x00, 0x01});
    EXPECT_EQ(d.function_name, "Read Coils");
    EXPECT_TRUE(d.exception);
    EXPECT_EQ(d.exception_code, 0x02);
    EXPECT_EQ(d.summary, "exception 02 Illegal Data Address");
    EXPECT_TRUE(d.notes.empty()) << texts(d);
    EXPECT_TRUE(d.blocks.empty());
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

TEST(DecoderException, UnknownCode) {
    EXPECT_EQ(exception_name(0x09), nullptr);
    EXPECT_EQ(exception_name(0x00), nullptr);
    const DecodedPdu d = response({0x90, 0x0C});
    EXPECT_EQ(d.function_name, "Write Multiple Registers");
    EXPECT_EQ(d.summary, "exception 0C unknown exception code");
    EXPECT_EQ(d.exception_code, 0x0C);
    EXPECT_EQ(ids(d), Ids{"pdu.illegal_value"});
}

TEST(DecoderException, CodeMissingOrExtraBytes) {
    const DecodedPdu missing = response({0x83});
    EXPECT_TRUE(missing.exception);
    EXPECT_EQ(missing.summary, "exception");
    EXPECT_EQ(ids(missing), Ids{"pdu.malformed"});
    const DecodedPdu extra = response({0x83, 0x02, 0x00});
    EXPECT_EQ(extra.summary, "exception 02 Illegal Data Address");
    EXPECT_EQ(ids(extra), Ids{"pdu.malformed"});
}

TEST(DecoderException, ToReadDeviceIdentification) {
    const DecodedPdu d = response({0xAB, 0x01}, {0x2B, 0x0E, 0x01, 0x00});
    EXPECT_EQ(d.function_name, "Read Device Identification");
    EXPECT_EQ(d.summary, "exception 01 Illegal Function");
    EXPECT_EQ(response({0xAB, 0x01}).function_name, "Encapsulated Interface Transport");
}

// ---- Unknown function codes ----

TEST(DecoderUnknownFunction, DataShownAsHex) {
    const DecodedPdu d = request({0x41, 0x2A, 0x00, 0x15});
    EXPECT_EQ(d.function_name, "Function 0x41");
    EXPECT_EQ(d.summary, "2A 00 15");
    EXPECT_EQ(ids(d), Ids{"pdu.unknown_function"});
    EXPECT_EQ(d.notes[0].text, "user-defined function code 0x41");
    const DecodedPdu empty = response({0x09});
    EXPECT_EQ(empty.function_name, "Function 0x09");
    EXPECT_EQ(empty.summary, "");
    EXPECT_EQ(ids(empty), Ids{"pdu.unknown_function"});
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

TEST(DecoderDiagnostics, EchoOfDataBeyondALegalFrameIsCounted) {
    Bytes asked{0x08, 0x00, 0x00};
    asked.resize(asked.size() + 300'000, 0x11);
    Bytes echoed = asked;
    echoed.back() = 0x22;
    const DecodedPdu d = response(echoed, asked);
    EXPECT_EQ(ids(d), Ids{"pdu.request_mismatch"});
    const std::string shown = data_bytes(std::span(asked).subspan(3, kMaxPduDataShown));
    const std::string rest = " ... (+299748 more)";  // 300,000 - 252
    EXPECT_EQ(d.notes[0].text, "echo differs from the request (" + shown + rest + ")");
    const std::string echoed_shown =
        data_bytes(std::span(echoed).subspan(3, kMaxPduDataShown));
    EXPECT_EQ(d.summary, "Return Query Data " + echoed_shown + rest);
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

TEST(DecoderTruncated, EmptyPdu) {
    const DecodedPdu q = request({});
    EXPECT_EQ(ids(q), Ids{"pdu.malformed"});
    EXPECT_EQ(q.summary, "");
    EXPECT_EQ(ids(response({}, {0x03, 0x00, 0x00, 0x00, 0x01})), Ids{"pdu.malformed"});
}

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

TEST(DecoderTruncated, ByteCountBeyondTheData) {
    const DecodedPdu d = response({0x03, 0xFA, 0x00, 0x01}, {0x03, 0x00, 0x00, 0x00, 0x7D});
    EXPECT_EQ(ids(d), Ids{"pdu.byte_count_mismatch"});
    EXPECT_EQ(d.summary, "1 register: 0x0001");
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
