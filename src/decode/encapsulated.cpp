// 6.19 Encapsulated Interface Transport (2B): 6.21 Read Device Identification (MEI type
// 0E) and 6.20 CANopen General Reference (MEI type 0D), which has no layout of its own and
// is shown as bytes.
//
//   request   +----+----+---------------------+-----------+
//             | 2B | 0E | read device id code | object id |
//             +----+----+---------------------+-----------+
//   response  +----+----+------+------------+------+-----------+-------+---------+
//             | 2B | 0E | code | conformity | more | next obj  | count | objects |
//             +----+----+------+------------+------+-----------+-------+---------+
//   object    | id | length | value (length bytes) |
#include <fmt/format.h>

#include <array>

#include "decode/pdu_decoders.hpp"
#include "decode/pdu_decoding.hpp"

namespace rtuscope {
namespace {

constexpr std::uint8_t kMeiCanopen = 0x0D;

// 6.21: read device id codes 01-04, and the objects 00-06 (07-7F reserved, 80-FF private).
constexpr std::array<const char*, 5> kReadDeviceIdCodes = {nullptr, "basic", "regular", "extended",
                                                           "specific"};
constexpr std::array<const char*, 7> kDeviceObjects = {
    "VendorName",  "ProductCode", "MajorMinorRevision", "VendorUrl",
    "ProductName", "ModelName",   "UserApplicationName"};
constexpr std::array<std::uint8_t, 6> kConformityLevels = {0x01, 0x02, 0x03, 0x81, 0x82, 0x83};

const char* read_device_id_code_name(std::uint8_t code) {
    return code < kReadDeviceIdCodes.size() ? kReadDeviceIdCodes[code] : nullptr;
}

// "basic", or "code 0x07" for a code out of range.
void append_read_device_id_code(std::string& out, std::uint8_t code) {
    if (const char* name = read_device_id_code_name(code)) {
        out += name;
    } else {
        fmt::format_to(std::back_inserter(out), "code 0x{:02X}", code);
    }
}

void check_read_device_id_code(PduDecoding& d, std::optional<std::uint8_t> code) {
    if (code && read_device_id_code_name(*code) == nullptr) {
        d.note(note_id::illegal_value,
               fmt::format("read device id code 0x{:02X} out of range 1..4", *code));
    }
}

void decode_device_id_request(PduDecoding& d) {
    d.expect_size(4);
    const auto code = u8_at(d.data, 1);
    const auto object = u8_at(d.data, 2);
    std::string& s = d.out.summary;
    if (code) append_read_device_id_code(s, *code);
    if (object) {
        append_separator(s, ", ");
        fmt::format_to(std::back_inserter(s), "object 0x{:02X}", *object);
    }
    check_read_device_id_code(d, code);
}

// "VendorName=\"ACME\"" for each object, at most `count`, from data byte 6 on.
void decode_device_objects(PduDecoding& d, std::uint8_t count, std::string& s) {
    std::string objects;
    std::size_t n = 0;
    std::size_t at = 6;
    for (; n < count && at < d.data.size(); ++n) {
        const std::uint8_t id = d.data[at];
        const auto length = u8_at(d.data, at + 1);
        const Bytes value = length ? slice(d.data, at + 2, *length) : Bytes{};
        if (n != 0) objects += ", ";
        if (id < kDeviceObjects.size()) {
            objects += kDeviceObjects[id];
        } else {
            fmt::format_to(std::back_inserter(objects), "object 0x{:02X}", id);
        }
        objects += '=';
        append_quoted(objects, value);
        if (!length || value.size() < *length) {
            d.note(note_id::malformed,
                   fmt::format("object 0x{:02X} cut short: {} bytes announced, {} present", id,
                               length ? *length : 0, value.size()));
        }
        at += 2U + (length ? std::size_t{*length} : 0U);
    }
    if (n < count) {
        d.note(note_id::malformed, fmt::format("{} {} announced, {} present", count,
                                               plural(count, "object", "objects"), n));
    }
    if (at < d.data.size()) {
        const std::size_t left = d.data.size() - at;
        d.note(note_id::malformed,
               fmt::format("{} {} after the last object", left, plural(left, "byte", "bytes")));
    }
    append_separator(s, ", ");
    append_counted(s, n, "object", "objects");
    if (n != 0) {
        s += ": ";
        s += objects;
    }
}

void decode_device_id_response(PduDecoding& d) {
    const auto code = u8_at(d.data, 1);
    const auto conformity = u8_at(d.data, 2);
    const auto more = u8_at(d.data, 3);
    const auto next = u8_at(d.data, 4);
    const auto count = u8_at(d.data, 5);
    d.expect_header(7);

    std::string& s = d.out.summary;
    if (code) append_read_device_id_code(s, *code);
    for (const auto& [label, value] :
         {std::pair{"conformity", conformity}, std::pair{"more", more}, std::pair{"next", next}}) {
        if (!value) continue;
        append_separator(s, ", ");
        fmt::format_to(std::back_inserter(s), "{} 0x{:02X}", label, *value);
    }
    check_read_device_id_code(d, code);
    if (conformity && std::find(kConformityLevels.begin(), kConformityLevels.end(), *conformity) ==
                          kConformityLevels.end()) {
        d.note(note_id::illegal_value, fmt::format("conformity level 0x{:02X}", *conformity));
    }
    if (more && *more != 0x00 && *more != 0xFF) {
        d.note(note_id::illegal_value,
               fmt::format("more follows 0x{:02X}, 0x00 or 0xFF expected", *more));
    }
    if (d.has_request && code) {
        const auto asked = u8_at(d.req, 1);
        if (asked && *asked != *code) {
            std::string text = "request was ";
            append_read_device_id_code(text, *asked);
            d.note(note_id::request_mismatch, text);
        }
    }
    if (count) decode_device_objects(d, *count, s);
}

}  // namespace

void decode_encapsulated_interface(PduDecoding& d) {
    const auto mei = u8_at(d.data, 0);
    if (!mei) {
        d.expect_header(2);
        return;
    }
    if (*mei == kMeiDeviceIdentification) {
        d.out.function_name = kDeviceIdentificationName;
        if (d.is_response()) {
            decode_device_id_response(d);
        } else {
            decode_device_id_request(d);
        }
        return;
    }
    const Bytes rest = slice(d.data, 1);
    std::string& s = d.out.summary;
    if (*mei == kMeiCanopen) {
        s += "CANopen General Reference";
    } else {
        fmt::format_to(std::back_inserter(s), "MEI type 0x{:02X}", *mei);
    }
    if (!rest.empty()) {
        s += ": ";
        append_data_bytes(s, rest);
    }
    if (*mei != kMeiCanopen) {
        d.note(note_id::unknown_function, fmt::format("reserved MEI type 0x{:02X}", *mei));
    }
}

}  // namespace rtuscope
