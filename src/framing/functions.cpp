// The function-code table. Each entry's lengths follow the request and response layouts
// of the MODBUS Application Protocol Specification V1.1b3, section 6 (the byte diagrams
// are beside the decoders in decode/), plus 3 bytes of address and CRC.
#include "framing/functions.hpp"

#include <fmt/format.h>

#include <array>

#include "decode/pdu_decoders.hpp"

namespace rtuscope {
namespace {

// `total` once it is known and within the serial-line ADU limit.
FrameLength checked(std::size_t total) {
    return total <= kMaxAdu ? FrameLength::fixed_at(total) : FrameLength::no_reading();
}

// 08 Diagnostics (6.8): sub-function 0000 echoes any amount of data; the others carry one
// data word.
FrameLength diagnostics_length(std::span<const std::uint8_t> head) {
    if (head.size() < 4) return FrameLength::need(4);
    return (head[2] == 0 && head[3] == 0) ? FrameLength::search_crc() : FrameLength::fixed_at(8);
}

// 18 Read FIFO Queue answer (6.18): addr fc count(2) fifo-count(2) values; the 2-byte
// count covers the FIFO count and the values.
FrameLength fifo_answer_length(std::span<const std::uint8_t> head) {
    if (head.size() < 4) return FrameLength::need(4);
    const std::size_t count = (std::size_t{head[2]} << 8) | head[3];
    return checked(4 + count + 2);
}

// 2B Encapsulated Interface Transport (6.19): only MEI type 0E, Read Device Identification
// (6.21), has a layout; its request is addr fc 0E code object.
FrameLength encapsulated_request_length(std::span<const std::uint8_t> head) {
    if (head.size() < 3) return FrameLength::need(3);
    return head[2] == 0x0E ? FrameLength::fixed_at(7) : FrameLength::search_crc();
}

// 2B / 0E answer: addr fc mei code conformity more next count, then the objects, each id,
// length, value.
FrameLength encapsulated_answer_length(std::span<const std::uint8_t> head) {
    if (head.size() < 3) return FrameLength::need(3);
    if (head[2] != 0x0E) return FrameLength::search_crc();
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

using L = LengthRule;
constexpr auto kFixed4 = L::fixed(4);      // the function code alone
constexpr auto kFixed8 = L::fixed(8);      // two data words
constexpr auto kCounted2 = L::counted(2);  // addr fc count data

// The section 6 entries, in code order. Quantity limits from the request descriptions.
FunctionSpec entry(std::uint8_t code, const char* name, LengthRule request, LengthRule response,
                   Answer answer, DataTable table, DataAccess access, std::uint16_t max_quantity,
                   PduDecoder decode_request, PduDecoder decode_response,
                   RequestWord request_word = RequestWord::none, bool answer_repeats_word = false) {
    return {code,         name,         request,
            response,     answer,       table,
            access,       max_quantity, request_word,
            answer_repeats_word, decode_request, decode_response, {}};
}

std::array<FunctionSpec, 128> make_table() {
    using enum DataTable;
    constexpr DataAccess read = DataAccess::read;
    constexpr DataAccess write = DataAccess::write;
    constexpr DataAccess read_write = DataAccess::read_write;
    constexpr Answer echo = Answer::echo;
    constexpr Answer reply = Answer::reply;
    constexpr RequestWord quantity = RequestWord::quantity;
    constexpr RequestWord on_off = RequestWord::on_off;
    // clang-format off
    const FunctionSpec standard_entries[] = {
        // code, name, request length, answer length, answer, data, access, max quantity,
        // request decoder, answer decoder, the request's word, whether the answer repeats it
        entry(0x01, "Read Coils", kFixed8, kCounted2, reply, coils, read, 2000,  // 6.1
              decode_read_request, decode_read_bits_response, quantity),
        entry(0x02, "Read Discrete Inputs", kFixed8, kCounted2, reply, discrete_inputs, read,
              2000, decode_read_request, decode_read_bits_response, quantity),  // 6.2
        entry(0x03, "Read Holding Registers", kFixed8, kCounted2, reply, holding_registers, read,
              125, decode_read_request, decode_read_registers_response, quantity),  // 6.3
        entry(0x04, "Read Input Registers", kFixed8, kCounted2, reply, input_registers, read,
              125, decode_read_request, decode_read_registers_response, quantity),  // 6.4
        entry(0x05, "Write Single Coil", kFixed8, kFixed8, echo, coils, write, 0,  // 6.5
              decode_write_single_coil, decode_write_single_coil, on_off, true),
        entry(0x06, "Write Single Register", kFixed8, kFixed8, echo, holding_registers, write,
              0, decode_write_single_register, decode_write_single_register,  // 6.6
              RequestWord::none, true),
        entry(0x07, "Read Exception Status", kFixed4, L::fixed(5), reply, none, DataAccess::none,
              0, decode_bare_request, decode_exception_status_response),  // 6.7
        entry(0x08, "Diagnostics", L::computed(diagnostics_length),  // 6.8
              L::computed(diagnostics_length), echo, none, DataAccess::none, 0,
              decode_diagnostics, decode_diagnostics),
        entry(0x0B, "Get Comm Event Counter", kFixed4, kFixed8, reply, none, DataAccess::none,
              0, decode_bare_request, decode_comm_event_counter_response),  // 6.9
        entry(0x0C, "Get Comm Event Log", kFixed4, kCounted2, reply, none, DataAccess::none, 0,
              decode_bare_request, decode_comm_event_log_response),  // 6.10
        entry(0x0F, "Write Multiple Coils", L::counted(6), kFixed8, reply, coils, write, 1968,
              decode_write_multiple_request, decode_write_multiple_response,  // 6.11
              quantity, true),
        entry(0x10, "Write Multiple Registers", L::counted(6), kFixed8, reply, holding_registers,
              write, 123, decode_write_multiple_request, decode_write_multiple_response,  // 6.12
              quantity, true),
        entry(0x11, "Report Server ID", kFixed4, kCounted2, reply, none, DataAccess::none, 0,
              decode_bare_request, decode_report_server_id_response),  // 6.13
        entry(0x14, "Read File Record", kCounted2, kCounted2, reply, none, DataAccess::none, 0,
              decode_read_file_request, decode_read_file_response),  // 6.14
        entry(0x15, "Write File Record", kCounted2, kCounted2, echo, none, DataAccess::none, 0,
              decode_write_file_record, decode_write_file_record),  // 6.15
        entry(0x16, "Mask Write Register", L::fixed(10), L::fixed(10), echo, holding_registers,
              write, 0, decode_mask_write_register, decode_mask_write_register),  // 6.16
        // 6.17: the read quantity's limit; the write part's (121) is the decoder's.
        entry(0x17, "Read/Write Multiple Registers", L::counted(10), kCounted2, reply,
              holding_registers, read_write, 125, decode_read_write_request,
              decode_read_registers_response, quantity),
        entry(0x18, "Read FIFO Queue", L::fixed(6), L::computed(fifo_answer_length), reply, none,
              DataAccess::none, 31, decode_read_fifo_request, decode_read_fifo_response),  // 6.18
        entry(0x2B, "Encapsulated Interface Transport",  // 6.19-6.21
              L::computed(encapsulated_request_length), L::computed(encapsulated_answer_length),
              reply, none, DataAccess::none, 0, decode_encapsulated_interface,
              decode_encapsulated_interface),
    };
    // clang-format on
    std::array<FunctionSpec, 128> table;
    for (std::size_t code = 0; code < table.size(); ++code) {
        const auto fc = static_cast<std::uint8_t>(code);
        table[code] = entry(fc, "", L::search(), L::search(), reply, none, DataAccess::none, 0,
                            decode_unknown_function, decode_unknown_function);
        table[code].name = fmt::format("Function 0x{:02X}", fc);
    }
    for (const FunctionSpec& spec : standard_entries) table[spec.code] = spec;
    return table;
}

// Made before main() runs: looked up at every byte the framer tries, so no guard of a
// function-local static in the way.
const std::array<FunctionSpec, 128> kFunctions = make_table();

// The standard rules have no state: one instance serves every pipeline.
const ProtocolRules kStandardRules;

}  // namespace

FrameLength LengthRule::of(std::span<const std::uint8_t> head) const {
    switch (kind) {
        case Kind::fixed:
            return FrameLength::fixed_at(n);
        case Kind::counted:
            if (head.size() <= n) return FrameLength::need(std::size_t{n} + 1);
            return checked(std::size_t{n} + 1 + head[n] + 2);
        case Kind::search:
            return FrameLength::search_crc();
        case Kind::computed:
            return compute(head);
        case Kind::none:
        case Kind::standard:
            break;
    }
    return FrameLength::no_reading();
}

const FunctionSpec& standard_function(std::uint8_t code) {
    return kFunctions[code & 0x7FU];
}

const FunctionSpec& ProtocolRules::function(std::uint8_t /*slave*/, std::uint8_t code) const {
    return standard_function(code);
}

bool ProtocolRules::is_broadcast(std::uint8_t slave) const {
    return slave == 0;
}

bool ProtocolRules::answers_errors(std::uint8_t /*slave*/) const {
    return true;
}

FrameLengths ProtocolRules::frame_lengths(std::span<const std::uint8_t> head) const {
    if (head.size() < 2) return {FrameLength::need(2), FrameLength::need(2)};
    const std::uint8_t code = head[1];
    // An exception answer is addr, fc|0x80, exception code, CRC (section 7); no request
    // has the exception bit.
    if (code & 0x80U) return {FrameLength::no_reading(), FrameLength::fixed_at(5)};
    const FunctionSpec& spec = function(head[0], code);
    const FrameLength request = spec.request_length.kind == LengthRule::Kind::standard
                                    ? standard_function(code).request_length.of(head)
                                    : spec.request_length.of(head);
    switch (spec.answer) {
        case Answer::echo:
            return {request, request};
        case Answer::none:
            return {request, FrameLength::no_reading()};
        case Answer::reply:
            break;
    }
    return {request, spec.response_length.of(head)};
}

const ProtocolRules& standard_rules() {
    return kStandardRules;
}

}  // namespace rtuscope
