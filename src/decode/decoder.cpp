// Decoding one PDU: its function's entry names the decoder; exception responses (section
// 7) and codes without a public layout (section 5, Annex A) are decoded here.
#include "decode/decoder.hpp"

#include <fmt/format.h>

#include <array>

#include "decode/pdu_decoders.hpp"
#include "decode/pdu_decoding.hpp"
#include "util/text.hpp"

namespace rtuscope {
namespace {

// Section 7, "MODBUS Exception Codes"; nullptr where the code is not defined.
constexpr std::array<const char*, 12> kExceptionNames = {
    nullptr,
    "Illegal Function",
    "Illegal Data Address",
    "Illegal Data Value",
    "Server Device Failure",
    "Acknowledge",
    "Server Device Busy",
    "Negative Acknowledge",
    "Memory Parity Error",
    nullptr,
    "Gateway Path Unavailable",
    "Gateway Target Device Failed to Respond",
};

// Annex A: the public codes set aside for users, and those reserved.
struct CodeRange {
    std::uint8_t first;
    std::uint8_t last;
};
constexpr std::array<CodeRange, 2> kUserDefinedCodes = {{{0x41, 0x48}, {0x64, 0x6E}}};
constexpr std::array<std::uint8_t, 11> kReservedCodes = {0x09, 0x0A, 0x0D, 0x0E, 0x29, 0x2A,
                                                         0x5A, 0x5B, 0x7D, 0x7E, 0x7F};

// Section 7: exception response, fc | 0x80 followed by one exception code.
//
//   +---------+----------------+
//   | fc|0x80 | exception code |
//   +---------+----------------+
//       1            1
void decode_exception_response(PduDecoding& d) {
    d.out.exception = true;
    // An exception to a 2B/0E request is about Read Device Identification.
    if (d.has_request && d.spec.code == 0x2B && u8_at(d.req, 0) == kMeiDeviceIdentification) {
        d.out.function_name = kDeviceIdentificationName;
    }
    const auto code = u8_at(d.data, 0);
    if (!code) {
        d.out.summary += "exception";
        d.note(note_id::malformed, "exception code missing");
        return;
    }
    d.expect_size(2);
    d.out.exception_code = *code;
    const char* name = exception_name(*code);
    const std::string_view text = name ? name : "unknown exception code";
    append_with(d.out.summary, 10 + 2 + 1 + text.size(), [&](char* p) {
        p = write_text(p, "exception ");
        p = write_hex(p, std::span(&*code, 1), false);
        *p++ = ' ';
        return write_text(p, text);
    });
    if (!name) {
        d.note(note_id::illegal_value,
               fmt::format("exception code 0x{:02X} is not defined by the specification", *code));
    }
}

}  // namespace

void PduDecoding::note_size(std::size_t n) {
    note(note_id::malformed, fmt::format("PDU too {}: {} bytes expected, {} present",
                                         pdu.size() < n ? "short" : "long", n, pdu.size()));
}

void PduDecoding::note_count(std::size_t count, std::size_t present) {
    note(note_id::byte_count_mismatch, fmt::format("byte count {}, {} {} present", count, present,
                                                   plural(present, "byte", "bytes")));
}

// Function codes without a public layout: the data as bytes.
void decode_unknown_function(PduDecoding& d) {
    append_data_bytes(d.out.summary, d.data);
    const std::uint8_t fc = d.fc;
    const char* why = "function code 0x{:02X} is not defined by the specification";
    if (std::any_of(kUserDefinedCodes.begin(), kUserDefinedCodes.end(),
                    [&](CodeRange r) { return fc >= r.first && fc <= r.last; })) {
        why = "user-defined function code 0x{:02X}";
    } else if (std::find(kReservedCodes.begin(), kReservedCodes.end(), fc) !=
               kReservedCodes.end()) {
        why = "reserved function code 0x{:02X}";
    }
    d.note(note_id::unknown_function, fmt::format(fmt::runtime(why), fc));
}

void DataBlock::clear() {
    table = DataTable::holding_registers;
    start = 0;
    values.clear();
    write = false;
    custom_table.clear();
}

void DecodedPdu::clear() {
    function = nullptr;
    function_name = {};
    summary.clear();
    exception = false;
    exception_code = 0;
    notes.clear();
    blocks.clear();
}

void decode_pdu(const FunctionSpec& spec, std::span<const std::uint8_t> pdu, Role role,
                std::span<const std::uint8_t> request_pdu, DecodedPdu& out) {
    out.clear();
    PduDecoding d(spec, out);
    d.pdu = pdu;
    d.role = role;
    if (pdu.empty()) {
        d.note(note_id::malformed, "empty PDU: no function code");
        return;
    }
    out.function = &spec;
    out.function_name = spec.name;
    d.fc = pdu[0];
    d.data = pdu.subspan(1);
    if (role == Role::response && !request_pdu.empty()) {
        if (request_pdu[0] == (d.fc & 0x7FU)) {
            d.req = request_pdu.subspan(1);
            d.has_request = true;
        } else {
            d.note(note_id::request_mismatch,
                   fmt::format("request was function 0x{:02X}", request_pdu[0]));
        }
    }
    // An exception is recognisable by its shape whatever role the pairing guessed.
    if ((d.fc & 0x80U) != 0) {
        decode_exception_response(d);
    } else if (role == Role::response) {
        spec.decode_response(d);
    } else {
        spec.decode_request(d);
    }
}

void append_data_bytes(std::string& out, std::span<const std::uint8_t> data) {
    const auto shown = data.first(std::min(data.size(), kMaxPduDataShown));
    append_with(out, 3 * shown.size(), [&](char* p) { return write_hex(p, shown, true); });
    if (shown.size() < data.size()) {
        fmt::format_to(std::back_inserter(out), " ... (+{} more)", data.size() - shown.size());
    }
}

const char* exception_name(std::uint8_t code) {
    return code < kExceptionNames.size() ? kExceptionNames[code] : nullptr;
}

}  // namespace rtuscope
