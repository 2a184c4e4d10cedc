// Diagnostics (section 5.1) of serial-line devices: 6.7 Read Exception Status, 6.8
// Diagnostics, 6.9 Get Comm Event Counter, 6.10 Get Comm Event Log, 6.13 Report Server ID.
#include <fmt/format.h>

#include <array>

#include "decode/pdu_decoders.hpp"
#include "decode/pdu_decoding.hpp"

namespace rtuscope {
namespace {

constexpr std::size_t kMaxCommEvents = 64;  // 6.10

}  // namespace

// 6.7 Read Exception Status (07), 6.9 Get Comm Event Counter (0B), 6.10 Get Comm Event
// Log (0C), 6.13 Report Server ID (11): the request is the function code alone.
void decode_bare_request(PduDecoding& d) {
    d.expect_size(1);
}

// 6.7 response: fc, one byte of eight exception status outputs.
void decode_exception_status_response(PduDecoding& d) {
    d.expect_size(2);
    if (const auto status = u8_at(d.data, 0)) {
        fmt::format_to(std::back_inserter(d.out.summary), "status 0x{:02X}", *status);
    }
}

// 6.9 response: fc, status word (FFFF = busy with an earlier command), event count.
void decode_comm_event_counter_response(PduDecoding& d) {
    d.expect_size(5);
    const auto status = u16_at(d.data, 0);
    const auto events = u16_at(d.data, 2);
    std::string& s = d.out.summary;
    if (status) fmt::format_to(std::back_inserter(s), "status 0x{:04X}", *status);
    if (events) {
        append_separator(s, ", ");
        fmt::format_to(std::back_inserter(s), "event count {}", *events);
    }
    if (status && *status != 0x0000 && *status != 0xFFFF) {
        d.note(note_id::illegal_value,
               fmt::format("status 0x{:04X}, 0x0000 or 0xFFFF expected", *status));
    }
}

// 6.10 response
//
//   +----+-------+--------+-------------+---------------+----------------+
//   | fc | count | status | event count | message count | events (0..64) |
//   +----+-------+--------+-------------+---------------+----------------+
//     1      1       2           2              2          count - 6

void decode_comm_event_log_response(PduDecoding& d) {
    const auto count = u8_at(d.data, 0);
    if (!count) {
        d.expect_header(2);
        return;
    }
    const Bytes covered = d.counted_part(*count, slice(d.data, 1));
    if (*count < 6) {
        d.note(note_id::malformed, fmt::format("byte count {}, at least 6 expected", *count));
    }
    const auto status = u16_at(covered, 0);
    const auto event_count = u16_at(covered, 2);
    const auto message_count = u16_at(covered, 4);
    std::string& s = d.out.summary;
    if (status) fmt::format_to(std::back_inserter(s), "status 0x{:04X}", *status);
    if (event_count) {
        append_separator(s, ", ");
        fmt::format_to(std::back_inserter(s), "event count {}", *event_count);
    }
    if (message_count) {
        append_separator(s, ", ");
        fmt::format_to(std::back_inserter(s), "message count {}, ", *message_count);
        const Bytes events = slice(covered, 6);
        append_counted(s, events.size(), "event", "events");
        if (!events.empty()) {
            s += ": ";
            append_data_bytes(s, events);
        }
        if (events.size() > kMaxCommEvents) {
            d.note(note_id::illegal_value,
                   fmt::format("{} events, at most {}", events.size(), kMaxCommEvents));
        }
    }
}

// 6.13 response: fc, byte count, then server id, run indicator and additional data,
// all device-specific, so shown as bytes.
void decode_report_server_id_response(PduDecoding& d) {
    const auto count = u8_at(d.data, 0);
    if (!count) {
        d.expect_header(2);
        return;
    }
    const Bytes covered = d.counted_part(*count, slice(d.data, 1));
    append_counted(d.out.summary, covered.size(), "byte", "bytes");
    if (!covered.empty()) {
        d.out.summary += ": ";
        append_data_bytes(d.out.summary, covered);
    }
}

// ---------------------------------------------------------------------------------
// 6.8 Diagnostics (08), request and answer
//
//   +----+--------------+-----------------------------+
//   | fc | sub-function | data (one word; any for 00) |
//   +----+--------------+-----------------------------+
//     1         2                 2 (N for 00)
// Answers echo the request for 00, 01, 03, 0A and 14; the counters (02, 0B..12) answer
// with the value. 04 puts the server into listen-only mode and gets no answer.

namespace {

struct SubFunction {
    std::uint16_t code;
    const char* name;
    bool echoes;  // the answer repeats the request's data
};

// 6.8.1; the codes missing here are reserved (Annex A).
constexpr std::array<SubFunction, 15> kSubFunctions = {{
    {0x00, "Return Query Data", true},
    {0x01, "Restart Communications Option", true},
    {0x02, "Return Diagnostic Register", false},
    {0x03, "Change ASCII Input Delimiter", true},
    {0x04, "Force Listen Only Mode", true},
    {0x0A, "Clear Counters and Diagnostic Register", true},
    {0x0B, "Return Bus Message Count", false},
    {0x0C, "Return Bus Communication Error Count", false},
    {0x0D, "Return Bus Exception Error Count", false},
    {0x0E, "Return Server Message Count", false},
    {0x0F, "Return Server No Response Count", false},
    {0x10, "Return Server NAK Count", false},
    {0x11, "Return Server Busy Count", false},
    {0x12, "Return Bus Character Overrun Count", false},
    {0x14, "Clear Overrun Counter and Flag", true},
}};

const SubFunction* sub_function(std::uint16_t code) {
    for (const SubFunction& s : kSubFunctions) {
        if (s.code == code) return &s;
    }
    return nullptr;
}

// One data word reads best as a word; anything else (00 takes any length) as bytes.
void append_diagnostics_data(std::string& out, Bytes b) {
    if (b.size() == 2) {
        fmt::format_to(std::back_inserter(out), "0x{:04X}", (b[0] << 8) | b[1]);
    } else {
        append_data_bytes(out, b);
    }
}

}  // namespace

void decode_diagnostics(PduDecoding& d) {
    const auto sub = u16_at(d.data, 0);
    if (!sub) {
        d.expect_header(3);
        return;
    }
    const Bytes payload = slice(d.data, 2);
    const SubFunction* known = sub_function(*sub);
    std::string& s = d.out.summary;
    if (known != nullptr) {
        s += known->name;
    } else {
        fmt::format_to(std::back_inserter(s), "sub-function 0x{:04X}", *sub);
    }
    if (!payload.empty()) {
        s += ' ';
        append_diagnostics_data(s, payload);
    }
    if (known == nullptr) {
        d.note(note_id::unknown_function,
               fmt::format("reserved diagnostics sub-function 0x{:04X}", *sub));
        return;  // its data layout is unknown
    }
    if (*sub != 0x00) d.expect_size(5);

    const auto value = u16_at(payload, 0);
    if (!d.is_response() && value) {
        // The request data each sub-function takes (6.8.1).
        if (*sub == 0x01 && *value != 0x0000 && *value != 0xFF00) {
            d.note(note_id::illegal_value,
                   fmt::format("data 0x{:04X}, 0x0000 or 0xFF00 expected", *value));
        } else if (*sub == 0x03 && (*value & 0xFFU) != 0) {
            d.note(note_id::illegal_value,
                   fmt::format("data 0x{:04X}, a delimiter and 0x00 expected", *value));
        } else if (*sub != 0x00 && *sub != 0x01 && *sub != 0x03 && *value != 0x0000) {
            d.note(note_id::illegal_value, fmt::format("data 0x{:04X}, 0x0000 expected", *value));
        }
    }
    if (d.is_response() && d.has_request) {
        const auto asked = u16_at(d.req, 0);
        if (asked && *asked != *sub) {
            d.note(note_id::request_mismatch,
                   fmt::format("request was sub-function 0x{:04X}", *asked));
        } else if (asked && known->echoes) {
            const Bytes asked_data = slice(d.req, 2);
            if (!std::equal(payload.begin(), payload.end(), asked_data.begin(), asked_data.end())) {
                std::string text = "echo differs from the request (";
                append_diagnostics_data(text, asked_data);
                text += ')';
                d.note(note_id::request_mismatch, text);
            }
        }
    }
}

}  // namespace rtuscope
