// File record access (section 5.1): 6.14 Read File Record, 6.15 Write File Record.
#include <fmt/format.h>

#include <vector>

#include "decode/pdu_decoders.hpp"
#include "decode/pdu_decoding.hpp"

namespace rtuscope {
namespace {

constexpr std::uint8_t kFileReferenceType = 0x06;  // 6.14, 6.15
constexpr std::uint16_t kMaxFileRecord = 0x270F;   // 6.14, 6.15

struct FileRecord {
    std::uint16_t file = 0;
    std::uint16_t record = 0;
    std::uint16_t length = 0;  // in registers
};

// "file 4 record 0x0001 x2"
void append_file_record(std::string& out, const FileRecord& r) {
    fmt::format_to(std::back_inserter(out), "file {} record 0x{:04X} x{}", r.file, r.record,
                   r.length);
}

// Checks shared by the sub-requests of 14 and 15; `notes` is null for a request that
// is only read to explain its answer (its problems were reported on its own frame).
void check_file_reference(Notes* notes, std::size_t index, std::uint8_t type, const FileRecord& r) {
    if (notes == nullptr) return;
    if (type != kFileReferenceType) {
        notes->add(
            note_id::illegal_value,
            fmt::format("sub-request {}: reference type 0x{:02X}, 0x06 required", index + 1, type));
    }
    if (r.file == 0) {
        notes->add(note_id::illegal_value, fmt::format("sub-request {}: file number 0", index + 1));
    }
    if (r.record > kMaxFileRecord) {
        notes->add(note_id::illegal_value,
                   fmt::format("sub-request {}: record number 0x{:04X} above 0x270F", index + 1,
                               r.record));
    }
}

// 6.14 request
//
//   +----+------------+----------------------------------------------+
//   | fc | byte count | sub-requests, 7 bytes each:                   |
//   |    | 07..F5     | ref type 06 | file | record | record length    |
//   +----+------------+----------------------------------------------+
//     1        1              1        2      2          2

std::vector<FileRecord> read_file_sub_requests(Bytes groups, Notes* notes) {
    constexpr std::size_t kGroup = 7;
    std::vector<FileRecord> records;
    for (std::size_t at = 0; at < groups.size(); at += kGroup) {
        const Bytes g = slice(groups, at, kGroup);
        if (g.size() < kGroup) {
            if (notes != nullptr) {
                notes->add(note_id::malformed,
                           fmt::format("sub-request {} cut short: {} of 7 bytes",
                                       records.size() + 1, g.size()));
            }
            break;
        }
        const FileRecord r{*u16_at(g, 1), *u16_at(g, 3), *u16_at(g, 5)};
        check_file_reference(notes, records.size(), g[0], r);
        records.push_back(r);
    }
    return records;
}

// "2 sub-requests: " before a list of them
void append_list_head(std::string& out, std::size_t n, std::string_view one,
                      std::string_view many) {
    append_counted(out, n, one, many);
    if (n != 0) out += ": ";
}

}  // namespace

void decode_read_file_request(PduDecoding& d) {
    const auto count = u8_at(d.data, 0);
    if (!count) {
        d.expect_header(2);
        return;
    }
    const Bytes groups = d.counted_part(*count, slice(d.data, 1));
    if (*count < 0x07 || *count > 0xF5) {
        d.note(note_id::illegal_value, fmt::format("byte count {} out of range 7..245", *count));
    }
    const std::vector<FileRecord> records = read_file_sub_requests(groups, &d.out.notes);
    append_list_head(d.out.summary, records.size(), "sub-request", "sub-requests");
    for (std::size_t i = 0; i < records.size(); ++i) {
        if (i != 0) d.out.summary += ", ";
        append_file_record(d.out.summary, records[i]);
    }
}

// 6.14 response
//
//   +----+------------+---------------------------------------------+
//   | fc | byte count | sub-responses:                               |
//   |    |            | length | ref type 06 | record data           |
//   +----+------------+---------------------------------------------+
//     1        1          1          1        length - 1 (2 per register)

void decode_read_file_response(PduDecoding& d) {
    const auto count = u8_at(d.data, 0);
    if (!count) {
        d.expect_header(2);
        return;
    }
    const Bytes groups = d.counted_part(*count, slice(d.data, 1));
    const std::vector<FileRecord> asked =
        d.has_request
            ? read_file_sub_requests(slice(d.req, 1, d.req.empty() ? 0 : d.req[0]), nullptr)
            : std::vector<FileRecord>{};
    std::string parts;
    std::size_t n = 0;
    std::vector<std::uint16_t> values;
    for (std::size_t at = 0; at < groups.size(); ++n) {
        const std::uint8_t length = groups[at];
        const Bytes group = slice(groups, at + 1, length);
        if (group.size() < length) {
            d.note(note_id::malformed,
                   fmt::format("sub-response {} cut short: {} bytes announced, {} present", n + 1,
                               length, group.size()));
        }
        if (length % 2 == 0) {
            d.note(note_id::malformed,
                   fmt::format("sub-response {}: length {}, 1 + 2 per register expected", n + 1,
                               length));
        }
        if (const auto type = u8_at(group, 0); type && *type != kFileReferenceType) {
            d.note(note_id::illegal_value,
                   fmt::format("sub-response {}: reference type 0x{:02X}, 0x06 required", n + 1,
                               *type));
        }
        words_of(slice(group, 1), values);
        if (n != 0) parts += ", ";
        if (n < asked.size()) {
            append_file_record(parts, asked[n]);
            if (!values.empty()) parts += ": ";
            if (length != 1U + 2U * asked[n].length) {
                d.note(
                    note_id::byte_count_mismatch,
                    fmt::format("sub-response {}: length {}, {} {} asked need {}", n + 1, length,
                                asked[n].length, plural(asked[n].length, "register", "registers"),
                                1U + 2U * asked[n].length));
            }
        }
        append_word_list(parts, values);
        at += 1U + length;
    }
    if (d.has_request && n != asked.size()) {
        d.note(note_id::request_mismatch,
               fmt::format("{} {}, {} asked", n, plural(n, "sub-response", "sub-responses"),
                           asked.size()));
    }
    append_list_head(d.out.summary, n, "sub-response", "sub-responses");
    d.out.summary += parts;
}

// ---------------------------------------------------------------------------------
// 6.15 Write File Record (15), request and its echo
//
//   +----+------------+-------------------------------------------------------------+
//   | fc | byte count | sub-requests:                                                |
//   |    | 09..FB     | ref type 06 | file | record | record length | record data    |
//   +----+------------+-------------------------------------------------------------+
//     1        1            1         2      2          2          2 x record length

void decode_write_file_record(PduDecoding& d) {
    const auto count = u8_at(d.data, 0);
    if (!count) {
        d.expect_header(2);
        return;
    }
    const Bytes groups = d.counted_part(*count, slice(d.data, 1));
    if (*count < 0x09 || *count > 0xFB) {
        d.note(note_id::illegal_value, fmt::format("byte count {} out of range 9..251", *count));
    }
    std::string parts;
    std::size_t n = 0;
    std::vector<std::uint16_t> values;
    for (std::size_t at = 0; at < groups.size(); ++n) {
        const Bytes header = slice(groups, at, 7);
        if (header.size() < 7) {
            d.note(note_id::malformed,
                   fmt::format("sub-request {} cut short: {} of 7 bytes", n + 1, header.size()));
            break;
        }
        const FileRecord r{*u16_at(header, 1), *u16_at(header, 3), *u16_at(header, 5)};
        check_file_reference(&d.out.notes, n, header[0], r);
        words_of(slice(groups, at + 7, 2U * std::size_t{r.length}), values);
        if (values.size() < r.length) {
            d.note(note_id::malformed,
                   fmt::format("sub-request {} cut short: {} {} announced, {} present", n + 1,
                               r.length, plural(r.length, "register", "registers"), values.size()));
        }
        if (n != 0) parts += ", ";
        append_file_record(parts, r);
        if (!values.empty()) {
            parts += ": ";
            append_word_list(parts, values);
        }
        at += 7U + 2U * std::size_t{r.length};
    }
    append_list_head(d.out.summary, n, "sub-request", "sub-requests");
    d.out.summary += parts;
    if (d.is_response() && d.has_request &&
        !std::equal(d.data.begin(), d.data.end(), d.req.begin(), d.req.end())) {
        d.note(note_id::request_mismatch, "echo differs from the request");
    }
}

}  // namespace rtuscope
