// Decoder for the standard PDUs of the MODBUS Application Protocol Specification V1.1b3
// (modbus.org, 2012). Section numbers in the comments refer to that document.
//
// A PDU is the function code followed by its data; multi-byte fields are big-endian:
//
//   +----------+-------------------------------+
//   | function | data (0..252 bytes)           |
//   +----------+-------------------------------+
//   | fc|0x80  | exception code                |   exception response (section 7)
//   +----------+-------------------------------+
//
// The bytes come off a wire we do not control. Every read is bounds-checked through
// u8_at / u16_at / slice; a PDU that is cut short or too long is decoded as far as its
// bytes go and the problem becomes a Note, so decoding never throws and never stops.

#include "decode/decoder.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cstddef>
#include <limits>
#include <optional>
#include <string_view>
#include <utility>

#include "util/text_append.hpp"

namespace rtuscope {
namespace {

using Bytes = std::span<const std::uint8_t>;

// A summary stays one readable line: longer lists end in "... (+N more)". The values
// themselves all go into the DataBlocks.
constexpr std::size_t kListedWords = 8;
constexpr std::size_t kListedBits = 64;

// Limits from the request descriptions of section 6.
constexpr std::uint16_t kMaxReadBits = 2000;       // 6.1, 6.2
constexpr std::uint16_t kMaxReadRegisters = 125;   // 6.3, 6.4, 6.17 read part
constexpr std::uint16_t kMaxWriteBits = 1968;      // 6.11
constexpr std::uint16_t kMaxWriteRegisters = 123;  // 6.12
constexpr std::uint16_t kMaxReadWriteWrite = 121;  // 6.17 write part
constexpr std::uint16_t kMaxFifoCount = 31;        // 6.18
constexpr std::size_t kMaxCommEvents = 64;         // 6.9
constexpr std::uint8_t kFileReferenceType = 0x06;  // 6.14, 6.15
constexpr std::uint16_t kMaxFileRecord = 0x270F;   // 6.14, 6.15
constexpr std::uint16_t kCoilOn = 0xFF00;          // 6.5
constexpr std::uint16_t kCoilOff = 0x0000;

// ---------------------------------------------------------------------------------
// Bounds-checked access

std::optional<std::uint8_t> u8_at(Bytes b, std::size_t at) {
    if (at >= b.size()) return std::nullopt;
    return b[at];
}

std::optional<std::uint16_t> u16_at(Bytes b, std::size_t at) {
    if (at >= b.size() || b.size() - at < 2) return std::nullopt;
    return static_cast<std::uint16_t>((b[at] << 8) | b[at + 1]);
}

// At most `n` bytes of `b` from `at`; empty when `at` is past the end.
Bytes slice(Bytes b, std::size_t at, std::size_t n = std::numeric_limits<std::size_t>::max()) {
    if (at >= b.size()) return {};
    return b.subspan(at, std::min(n, b.size() - at));
}

// ---------------------------------------------------------------------------------
// Formatting

// Appends what `write` writes (at most `bound` characters) in one go: a summary's fields
// written to the stack and appended once cost one capacity check and one copy, where an
// append per field cost that each time.
template <typename Write>
void append_written(std::string& s, std::size_t bound, Write write) {
    constexpr std::size_t kStackChars = 192;
    if (bound > kStackChars) {
        append_with(s, bound, write);
        return;
    }
    char text[kStackChars];
    const char* const end = write(text);
    s.append(text, static_cast<std::size_t>(end - text));
}

// "1 register", "2 registers"
char* write_counted(char* p, std::size_t n, std::string_view one, std::string_view many) {
    p = write_uint(p, n);
    *p++ = ' ';
    return write_text(p, n == 1 ? one : many);
}

std::size_t counted_bound(std::string_view one, std::string_view many) {
    return kMaxUintChars + 1 + std::max(one.size(), many.size());
}

void append_counted(std::string& s, std::size_t n, std::string_view one, std::string_view many) {
    append_written(s, counted_bound(one, many),
                   [&](char* p) { return write_counted(p, n, one, many); });
}

std::string counted(std::size_t n, std::string_view one, std::string_view many) {
    std::string s;
    append_counted(s, n, one, many);
    return s;
}

// Summaries are built by appending to the record's reused string: the decoder runs once
// per frame, and a temporary string per field was a large part of its time.

// " ... (+12 more)" after a list cut short.
char* write_more(char* p, std::size_t more) {
    p = write_text(p, " ... (+");
    p = write_uint(p, more);
    return write_text(p, " more)");
}
constexpr std::size_t kMaxMoreChars = kMaxUintChars + 14;

constexpr std::size_t kMaxWordListChars = 7 * kListedWords + kMaxMoreChars;
constexpr std::size_t kMaxBitListChars = kListedBits + kMaxMoreChars;

char* write_word_list(char* p, std::span<const std::uint16_t> values) {
    const std::size_t listed = std::min(values.size(), kListedWords);
    if (listed != 0) p = write_hex4(p, values[0]);
    for (std::size_t i = 1; i < listed; ++i) {
        *p++ = ' ';
        p = write_hex4(p, values[i]);
    }
    if (values.size() > listed) p = write_more(p, values.size() - listed);
    return p;
}

void append_word_list(std::string& s, std::span<const std::uint16_t> values) {
    append_written(s, kMaxWordListChars, [&](char* p) { return write_word_list(p, values); });
}

std::string word_list(std::span<const std::uint16_t> values) {
    std::string s;
    append_word_list(s, values);
    return s;
}

char* write_bit_list(char* p, std::span<const std::uint16_t> bits) {
    const std::size_t listed = std::min(bits.size(), kListedBits);
    for (std::size_t i = 0; i < listed; ++i) *p++ = bits[i] != 0 ? '1' : '0';
    if (bits.size() > listed) p = write_more(p, bits.size() - listed);
    return p;
}

// ": 0x1818 0x0000" or ": 1011", nothing for no values.
constexpr std::size_t kMaxValuesChars = 2 + std::max(kMaxWordListChars, kMaxBitListChars);
char* write_values(char* p, std::span<const std::uint16_t> values, bool as_bits) {
    if (values.empty()) return p;
    p = write_text(p, ": ");
    return as_bits ? write_bit_list(p, values) : write_word_list(p, values);
}

void append_values(std::string& s, std::span<const std::uint16_t> values, bool as_bits) {
    append_written(s, kMaxValuesChars, [&](char* p) { return write_values(p, values, as_bits); });
}

// "2 registers: 0x1818 0x0000", "0 registers"
void append_listed(std::string& s, std::span<const std::uint16_t> values, std::string_view one,
                   std::string_view many, bool as_bits) {
    append_written(s, counted_bound(one, many) + kMaxValuesChars, [&](char* p) {
        return write_values(write_counted(p, values.size(), one, many), values, as_bits);
    });
}

std::string listed(std::span<const std::uint16_t> values, std::string_view one,
                   std::string_view many, bool as_bits) {
    std::string s;
    append_listed(s, values, one, many, as_bits);
    return s;
}

// Sized once and filled through a pointer: a push_back per value checked the capacity
// every time.
void words_of(Bytes b, std::vector<std::uint16_t>& v) {
    const std::size_t n = b.size() / 2;
    v.resize(n);
    std::uint16_t* const out = v.data();
    for (std::size_t i = 0; i < n; ++i) {
        out[i] = static_cast<std::uint16_t>((b[2 * i] << 8) | b[2 * i + 1]);
    }
}

std::vector<std::uint16_t> words_of(Bytes b) {
    std::vector<std::uint16_t> v;
    words_of(b, v);
    return v;
}

// Bits in address order: the LSB of the first byte is the first address (6.1).
void bits_of(Bytes b, std::size_t count, std::vector<std::uint16_t>& v) {
    count = std::min(count, b.size() * 8);
    v.resize(count);
    std::uint16_t* const out = v.data();
    for (std::size_t first = 0; first < count; first += 8) {
        const unsigned byte = b[first / 8];
        const std::size_t n = std::min<std::size_t>(8, count - first);
        for (std::size_t bit = 0; bit < n; ++bit) {
            out[first + bit] = static_cast<std::uint16_t>((byte >> bit) & 1U);
        }
    }
}

// Strings of Read Device Identification: printable ASCII as is, the rest escaped.
std::string quoted(Bytes b) {
    std::string s = "\"";
    for (std::uint8_t c : b) {
        if (c == '"' || c == '\\') {
            s += '\\';
            s += static_cast<char>(c);
        } else if (c >= 0x20 && c < 0x7F) {
            s += static_cast<char>(c);
        } else {
            s += fmt::format("\\x{:02X}", c);
        }
    }
    s += '"';
    return s;
}

std::string join(const std::vector<std::string>& parts, std::string_view sep) {
    std::string s;
    for (std::size_t i = 0; i < parts.size(); ++i) {
        if (i != 0) s += sep;
        s += parts[i];
    }
    return s;
}

constexpr const char* standard_name(std::uint8_t function) {
    const auto fc = static_cast<std::uint8_t>(function & 0x7FU);
    switch (fc) {
        case 0x01:
            return "Read Coils";
        case 0x02:
            return "Read Discrete Inputs";
        case 0x03:
            return "Read Holding Registers";
        case 0x04:
            return "Read Input Registers";
        case 0x05:
            return "Write Single Coil";
        case 0x06:
            return "Write Single Register";
        case 0x07:
            return "Read Exception Status";
        case 0x08:
            return "Diagnostics";
        case 0x0B:
            return "Get Comm Event Counter";
        case 0x0C:
            return "Get Comm Event Log";
        case 0x0F:
            return "Write Multiple Coils";
        case 0x10:
            return "Write Multiple Registers";
        case 0x11:
            return "Report Server ID";
        case 0x14:
            return "Read File Record";
        case 0x15:
            return "Write File Record";
        case 0x16:
            return "Mask Write Register";
        case 0x17:
            return "Read/Write Multiple Registers";
        case 0x18:
            return "Read FIFO Queue";
        case 0x2B:
            return "Encapsulated Interface Transport";
        default:
            return nullptr;
    }
}

// Every record is named: the names' lengths are counted at compile time, not per record.
constexpr std::size_t kFunctionCodes = 128;
constexpr std::array<std::string_view, kFunctionCodes> function_names() {
    std::array<std::string_view, kFunctionCodes> names{};
    for (std::size_t fc = 0; fc < kFunctionCodes; ++fc) {
        const char* name = standard_name(static_cast<std::uint8_t>(fc));
        if (name != nullptr) names[fc] = name;
    }
    return names;
}
constexpr auto kFunctionNames = function_names();

// ---------------------------------------------------------------------------------
// Decoding state and checks shared by the function codes

struct Decoder {
    explicit Decoder(DecodedPdu& pdu_out) : out(pdu_out) {}

    std::uint8_t fc = 0;
    Role role = Role::request;
    Bytes pdu;
    Bytes data;  // the PDU without its function code
    Bytes req;   // data of the request this answers (without function code)
    bool has_request = false;
    DecodedPdu& out;

    void note(const char* id, std::string text) { out.notes.push_back({id, std::move(text)}); }

    [[nodiscard]] bool is_response() const { return role == Role::response; }

    // A layout of exactly `n` PDU bytes, function code included.
    void expect_size(std::size_t n) {
        if (pdu.size() < n) {
            note(note_id::malformed,
                 fmt::format("PDU too short: {} bytes expected, {} present", n, pdu.size()));
        } else if (pdu.size() > n) {
            note(note_id::malformed,
                 fmt::format("PDU too long: {} bytes expected, {} present", n, pdu.size()));
        }
    }

    // A header of `n` PDU bytes before a counted part; true when it is all there.
    bool expect_header(std::size_t n) {
        if (pdu.size() >= n) return true;
        note(note_id::malformed,
             fmt::format("PDU too short: at least {} bytes expected, {} present", n, pdu.size()));
        return false;
    }

    // A byte count against the bytes that follow it; returns the bytes it covers.
    Bytes counted_part(std::size_t count, Bytes following) {
        if (following.size() != count) {
            note(note_id::byte_count_mismatch,
                 fmt::format("byte count {}, {} present", count,
                             counted(following.size(), "byte", "bytes")));
        }
        return slice(following, 0, count);
    }

    void check_quantity(std::uint16_t qty, std::uint16_t max, std::string_view what = "quantity") {
        if (qty == 0 || qty > max) {
            note(note_id::illegal_value, fmt::format("{} {} out of range 1..{}", what, qty, max));
        }
    }

    // Addresses are 16 bits; a range that wraps cannot be served by any device.
    void check_range(std::uint16_t start, std::uint16_t qty) {
        if (std::uint32_t{start} + qty > 0x10000U) {
            note(note_id::illegal_value,
                 fmt::format("0x{:04X} x{} runs past address 0xFFFF", start, qty));
        }
    }

    // An answer that repeats the first `n` data bytes of its request (05, 06, 08, 16, ...);
    // `text_of` describes the request when it does not.
    template <typename TextOf>
    void check_echo(std::size_t n, TextOf text_of) {
        if (!has_request || req.size() < n || data.size() < n) return;
        if (!std::equal(data.begin(), data.begin() + static_cast<std::ptrdiff_t>(n), req.begin())) {
            note(note_id::request_mismatch, fmt::format("request was {}", text_of(req)));
        }
    }

    // A data block for the profile layer, reusing the buffers of an earlier record's.
    DataBlock& add_block(DataTable table, std::uint16_t start, bool write) {
        // Usually the record's one block is the one spare: the lists change places, which
        // moves no block.
        if (out.blocks.empty() && out.spare_blocks.size() == 1) {
            out.blocks.swap(out.spare_blocks);
        } else if (out.spare_blocks.empty()) {
            out.blocks.emplace_back();
        } else {
            out.blocks.push_back(std::move(out.spare_blocks.back()));
            out.spare_blocks.pop_back();
        }
        DataBlock& block = out.blocks.back();
        block.table = table;
        block.start = start;
        block.values.clear();
        block.write = write;
        block.custom_table.clear();
        return block;
    }

    // Takes back the block just added (it turned out to carry nothing to explain).
    void drop_last_block() {
        if (out.blocks.size() == 1 && out.spare_blocks.empty()) {
            out.blocks.swap(out.spare_blocks);
            return;
        }
        out.spare_blocks.push_back(std::move(out.blocks.back()));
        out.blocks.pop_back();
    }
};

struct Range {
    std::uint16_t start = 0;
    std::uint16_t qty = 0;
};

std::optional<Range> range_at(Bytes b, std::size_t at) {
    const auto start = u16_at(b, at);
    const auto qty = u16_at(b, at + 2);
    if (!start || !qty) return std::nullopt;
    return Range{*start, *qty};
}

// The request this frame answers, when it is known and complete enough.
std::optional<Range> asked_range(const Decoder& d) {
    return d.has_request ? range_at(d.req, 0) : std::nullopt;
}

// "0x0013 x10" from whatever of the two fields is present.
constexpr std::size_t kMaxRangeChars = 6 + 2 + 5;
char* write_range(char* p, std::optional<std::uint16_t> start, std::optional<std::uint16_t> qty) {
    if (start) p = write_hex4(p, *start);
    if (qty) {
        p = write_text(p, start ? " x" : "x");
        p = write_uint(p, *qty);
    }
    return p;
}

void append_range(std::string& s, std::optional<std::uint16_t> start,
                  std::optional<std::uint16_t> qty) {
    append_written(s, kMaxRangeChars, [&](char* p) { return write_range(p, start, qty); });
}

std::string range_text(std::optional<std::uint16_t> start, std::optional<std::uint16_t> qty) {
    std::string s;
    append_range(s, start, qty);
    return s;
}

// ---------------------------------------------------------------------------------
// 6.1 Read Coils (01), 6.2 Read Discrete Inputs (02), 6.3 Read Holding Registers (03),
// 6.4 Read Input Registers (04): requests
//
//   +----+---------------+----------+
//   | fc | start address | quantity |
//   +----+---------------+----------+
//     1         2             2

void read_request(Decoder& d, std::uint16_t max_qty) {
    d.expect_size(5);
    const auto start = u16_at(d.data, 0);
    const auto qty = u16_at(d.data, 2);
    append_range(d.out.summary, start, qty);
    if (qty) d.check_quantity(*qty, max_qty);
    if (start && qty) d.check_range(*start, *qty);
}

// 6.1 / 6.2 responses: the bits packed eight to a byte, first address in the LSB.
//
//   +----+------------+----------------------+
//   | fc | byte count | bits, padded with 0  |
//   +----+------------+----------------------+
//     1        1          byte count

void read_bits_response(Decoder& d, DataTable table, std::string_view one, std::string_view many) {
    const auto count = u8_at(d.data, 0);
    if (!count) {
        d.expect_header(2);
        return;
    }
    const Bytes bytes = d.counted_part(*count, slice(d.data, 1));
    const auto asked = asked_range(d);
    if (asked) {
        const std::size_t need = (std::size_t{asked->qty} + 7) / 8;
        if (*count != need) {
            d.note(note_id::byte_count_mismatch,
                   fmt::format("byte count {}, {} asked need {}", *count,
                               counted(asked->qty, one, many), need));
        }
    }
    // Without the request the padding cannot be told from data: show every bit.
    const std::size_t n = asked ? std::size_t{asked->qty} : bytes.size() * 8;
    DataBlock& block = d.add_block(table, asked ? asked->start : 0, false);
    bits_of(bytes, n, block.values);
    append_listed(d.out.summary, block.values, one, many, true);
    if (!asked || block.values.empty()) d.drop_last_block();
}

// 6.3 / 6.4 / 6.17 responses: registers, two bytes each.
//
//   +----+------------+------------------------+
//   | fc | byte count | registers (2 bytes each) |
//   +----+------------+------------------------+
//     1        1           byte count

void read_registers_response(Decoder& d, DataTable table) {
    const auto count = u8_at(d.data, 0);
    if (!count) {
        d.expect_header(2);
        return;
    }
    const Bytes bytes = d.counted_part(*count, slice(d.data, 1));
    if (*count % 2 != 0) {
        d.note(note_id::malformed,
               fmt::format("byte count {} is not a whole number of registers", *count));
    }
    const auto asked = asked_range(d);  // 6.17 also starts with the read range
    if (asked && *count != 2U * asked->qty) {
        d.note(note_id::byte_count_mismatch,
               fmt::format("byte count {}, {} asked need {}", *count,
                           counted(asked->qty, "register", "registers"), 2U * asked->qty));
    }
    DataBlock& block = d.add_block(table, asked ? asked->start : 0, false);
    words_of(bytes, block.values);
    append_listed(d.out.summary, block.values, "register", "registers", false);
    if (!asked || block.values.empty()) d.drop_last_block();
}

// ---------------------------------------------------------------------------------
// 6.5 Write Single Coil (05), request and echo
//
//   +----+---------+------------------------+
//   | fc | address | FF00 = ON, 0000 = OFF  |
//   +----+---------+------------------------+
//     1       2               2

void append_single_coil(std::string& s, Bytes b) {
    const auto address = u16_at(b, 0);
    const auto value = u16_at(b, 2);
    append_written(s, 6 + 1 + 6, [&](char* p) {
        if (address) p = write_hex4(p, *address);
        if (value) {
            if (address) *p++ = ' ';
            if (*value == kCoilOn) {
                p = write_text(p, "ON");
            } else if (*value == kCoilOff) {
                p = write_text(p, "OFF");
            } else {
                p = write_hex4(p, *value);
            }
        }
        return p;
    });
}

std::string single_coil_text(Bytes b) {
    std::string s;
    append_single_coil(s, b);
    return s;
}

void write_single_coil(Decoder& d) {
    d.expect_size(5);
    const auto address = u16_at(d.data, 0);
    const auto value = u16_at(d.data, 2);
    append_single_coil(d.out.summary, d.data);
    if (value && *value != kCoilOn && *value != kCoilOff) {
        d.note(note_id::illegal_value,
               fmt::format("coil value 0x{:04X}, 0xFF00 or 0x0000 expected", *value));
    } else if (address && value) {
        d.add_block(DataTable::coils, *address, true)
            .values.push_back(static_cast<std::uint16_t>(*value == kCoilOn));
    }
    if (d.is_response()) d.check_echo(4, single_coil_text);
}

// 6.6 Write Single Register (06), request and echo
//
//   +----+---------+-------+
//   | fc | address | value |
//   +----+---------+-------+
//     1       2        2

void append_single_register(std::string& s, Bytes b) {
    const auto address = u16_at(b, 0);
    const auto value = u16_at(b, 2);
    append_written(s, 6 + 3 + 6 + 2 + 5 + 1, [&](char* p) {
        if (address) p = write_hex4(p, *address);
        if (value) {
            p = write_text(p, address ? " = " : "= ");
            p = write_hex4(p, *value);
            p = write_text(p, " (");
            p = write_uint(p, *value);
            *p++ = ')';
        }
        return p;
    });
}

std::string single_register_text(Bytes b) {
    std::string s;
    append_single_register(s, b);
    return s;
}

void write_single_register(Decoder& d) {
    d.expect_size(5);
    const auto address = u16_at(d.data, 0);
    const auto value = u16_at(d.data, 2);
    append_single_register(d.out.summary, d.data);
    if (address && value) {
        d.add_block(DataTable::holding_registers, *address, true).values.push_back(*value);
    }
    if (d.is_response()) d.check_echo(4, single_register_text);
}

// ---------------------------------------------------------------------------------
// 6.11 Write Multiple Coils (0F), 6.12 Write Multiple Registers (10): requests
//
//   +----+---------------+----------+------------+-----------------+
//   | fc | start address | quantity | byte count | values          |
//   +----+---------------+----------+------------+-----------------+
//     1         2             2           1        byte count

void write_multiple_request(Decoder& d, bool bits) {
    d.expect_header(6);
    const auto start = u16_at(d.data, 0);
    const auto qty = u16_at(d.data, 2);
    const auto count = u8_at(d.data, 4);
    append_range(d.out.summary, start, qty);
    if (qty) d.check_quantity(*qty, bits ? kMaxWriteBits : kMaxWriteRegisters);
    if (start && qty) d.check_range(*start, *qty);
    if (!count) return;

    const Bytes bytes = d.counted_part(*count, slice(d.data, 5));
    if (qty) {
        const std::size_t asked = *qty;
        const std::size_t need = bits ? (asked + 7) / 8 : 2 * asked;
        if (*count != need) {
            d.note(note_id::byte_count_mismatch,
                   fmt::format("byte count {}, {} need {}", *count,
                               bits ? counted(*qty, "coil", "coils")
                                    : counted(*qty, "register", "registers"),
                               need));
        }
    }
    DataBlock& block = d.add_block(bits ? DataTable::coils : DataTable::holding_registers,
                                   start.value_or(0), true);
    if (bits) {
        bits_of(bytes, qty ? std::size_t{*qty} : bytes.size() * 8, block.values);
    } else {
        words_of(bytes, block.values);
    }
    append_values(d.out.summary, block.values, bits);
    if (!start || block.values.empty()) d.drop_last_block();
}

// 0F / 10 responses: the start address and quantity written.
//
//   +----+---------------+----------+
//   | fc | start address | quantity |
//   +----+---------------+----------+

void write_multiple_response(Decoder& d, bool bits) {
    d.expect_size(5);
    const auto start = u16_at(d.data, 0);
    const auto qty = u16_at(d.data, 2);
    append_range(d.out.summary, start, qty);
    if (qty) d.check_quantity(*qty, bits ? kMaxWriteBits : kMaxWriteRegisters);
    if (const auto asked = asked_range(d);
        asked && start && qty && (asked->start != *start || asked->qty != *qty)) {
        d.note(note_id::request_mismatch,
               fmt::format("request was 0x{:04X} x{}", asked->start, asked->qty));
    }
}

// ---------------------------------------------------------------------------------
// 6.16 Mask Write Register (16), request and echo:
// result = (current AND and_mask) OR (or_mask AND NOT and_mask)
//
//   +----+---------+----------+---------+
//   | fc | address | AND mask | OR mask |
//   +----+---------+----------+---------+
//     1       2         2          2

std::string mask_write_text(Bytes b) {
    const auto address = u16_at(b, 0);
    const auto and_mask = u16_at(b, 2);
    const auto or_mask = u16_at(b, 4);
    std::vector<std::string> parts;
    if (address) parts.push_back(fmt::format("0x{:04X}", *address));
    if (and_mask) parts.push_back(fmt::format("AND 0x{:04X}", *and_mask));
    if (or_mask) parts.push_back(fmt::format("OR 0x{:04X}", *or_mask));
    return join(parts, " ");
}

void mask_write_register(Decoder& d) {
    d.expect_size(7);
    d.out.summary = mask_write_text(d.data);
    if (d.is_response()) d.check_echo(6, mask_write_text);
}

// ---------------------------------------------------------------------------------
// 6.17 Read/Write Multiple Registers (17), request; the write happens before the read.
//
//   +----+------------+----------+-------------+-----------+-------+--------------+
//   | fc | read start | read qty | write start | write qty | count | write values |
//   +----+------------+----------+-------------+-----------+-------+--------------+
//     1        2           2           2            2         1      byte count

void read_write_request(Decoder& d) {
    d.expect_header(10);
    const auto read_start = u16_at(d.data, 0);
    const auto read_qty = u16_at(d.data, 2);
    const auto write_start = u16_at(d.data, 4);
    const auto write_qty = u16_at(d.data, 6);
    const auto count = u8_at(d.data, 8);

    std::string s;
    if (read_start || read_qty) s = "read " + range_text(read_start, read_qty);
    if (write_start || write_qty) s += ", write " + range_text(write_start, write_qty);
    if (read_qty) d.check_quantity(*read_qty, kMaxReadRegisters, "read quantity");
    if (read_start && read_qty) d.check_range(*read_start, *read_qty);
    if (write_qty) d.check_quantity(*write_qty, kMaxReadWriteWrite, "write quantity");
    if (write_start && write_qty) d.check_range(*write_start, *write_qty);
    if (count) {
        const Bytes bytes = d.counted_part(*count, slice(d.data, 9));
        if (write_qty && *count != 2U * *write_qty) {
            d.note(note_id::byte_count_mismatch,
                   fmt::format("byte count {}, {} need {}", *count,
                               counted(*write_qty, "register", "registers"), 2U * *write_qty));
        }
        DataBlock& block = d.add_block(DataTable::holding_registers, write_start.value_or(0), true);
        words_of(bytes, block.values);
        append_values(s, block.values, false);
        if (!write_start || block.values.empty()) d.drop_last_block();
    }
    d.out.summary = std::move(s);
}

// ---------------------------------------------------------------------------------
// 6.18 Read FIFO Queue (18)
//
//   request   +----+--------------+
//             | fc | FIFO address |
//             +----+--------------+
//   response  +----+------------+------------+------------------+
//             | fc | byte count | FIFO count | values (<= 31)   |
//             +----+------------+------------+------------------+
//               1        2            2        2 x FIFO count
// The byte count covers the FIFO count and the values.

void read_fifo_request(Decoder& d) {
    d.expect_size(3);
    if (const auto address = u16_at(d.data, 0)) {
        d.out.summary = fmt::format("FIFO 0x{:04X}", *address);
    }
}

void read_fifo_response(Decoder& d) {
    const auto count = u16_at(d.data, 0);
    const auto fifo_count = u16_at(d.data, 2);
    if (!d.expect_header(5) && !count) return;
    Bytes covered;
    if (count) covered = d.counted_part(*count, slice(d.data, 2));
    if (fifo_count) {
        if (*fifo_count > kMaxFifoCount) {
            d.note(note_id::illegal_value,
                   fmt::format("FIFO count {}, at most {}", *fifo_count, kMaxFifoCount));
        }
        if (count && *count != 2U + 2U * *fifo_count) {
            d.note(note_id::byte_count_mismatch,
                   fmt::format("byte count {}, {} need {}", *count,
                               counted(*fifo_count, "value", "values"), 2U + 2U * *fifo_count));
        }
    }
    d.out.summary = listed(words_of(slice(covered, 2)), "value", "values", false);
}

// ---------------------------------------------------------------------------------
// 6.7 Read Exception Status (07), 6.9 Get Comm Event Counter (0B), 6.10 Get Comm Event
// Log (0C), 6.13 Report Server ID (11): the request is the function code alone.

void bare_request(Decoder& d) {
    d.expect_size(1);
}

// 6.7 response: fc, one byte of eight exception status outputs.
void read_exception_status_response(Decoder& d) {
    d.expect_size(2);
    if (const auto status = u8_at(d.data, 0)) {
        d.out.summary = fmt::format("status 0x{:02X}", *status);
    }
}

// 6.9 response: fc, status word (FFFF = busy with an earlier command), event count.
void comm_event_counter_response(Decoder& d) {
    d.expect_size(5);
    const auto status = u16_at(d.data, 0);
    const auto events = u16_at(d.data, 2);
    std::vector<std::string> parts;
    if (status) parts.push_back(fmt::format("status 0x{:04X}", *status));
    if (events) parts.push_back(fmt::format("event count {}", *events));
    d.out.summary = join(parts, ", ");
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

void comm_event_log_response(Decoder& d) {
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
    std::vector<std::string> parts;
    if (status) parts.push_back(fmt::format("status 0x{:04X}", *status));
    if (event_count) parts.push_back(fmt::format("event count {}", *event_count));
    if (message_count) {
        parts.push_back(fmt::format("message count {}", *message_count));
        const Bytes events = slice(covered, 6);
        std::string e = counted(events.size(), "event", "events");
        if (!events.empty()) e += ": " + data_bytes_text(events);
        parts.push_back(std::move(e));
        if (events.size() > kMaxCommEvents) {
            d.note(note_id::illegal_value,
                   fmt::format("{} events, at most {}", events.size(), kMaxCommEvents));
        }
    }
    d.out.summary = join(parts, ", ");
}

// 6.13 response: fc, byte count, then server id, run indicator and additional data,
// all device-specific, so shown as bytes.
void report_server_id_response(Decoder& d) {
    const auto count = u8_at(d.data, 0);
    if (!count) {
        d.expect_header(2);
        return;
    }
    const Bytes covered = d.counted_part(*count, slice(d.data, 1));
    d.out.summary = counted(covered.size(), "byte", "bytes");
    if (!covered.empty()) d.out.summary += ": " + data_bytes_text(covered);
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

const char* diagnostics_name(std::uint16_t sub) {
    switch (sub) {
        case 0x00:
            return "Return Query Data";
        case 0x01:
            return "Restart Communications Option";
        case 0x02:
            return "Return Diagnostic Register";
        case 0x03:
            return "Change ASCII Input Delimiter";
        case 0x04:
            return "Force Listen Only Mode";
        case 0x0A:
            return "Clear Counters and Diagnostic Register";
        case 0x0B:
            return "Return Bus Message Count";
        case 0x0C:
            return "Return Bus Communication Error Count";
        case 0x0D:
            return "Return Bus Exception Error Count";
        case 0x0E:
            return "Return Server Message Count";
        case 0x0F:
            return "Return Server No Response Count";
        case 0x10:
            return "Return Server NAK Count";
        case 0x11:
            return "Return Server Busy Count";
        case 0x12:
            return "Return Bus Character Overrun Count";
        case 0x14:
            return "Clear Overrun Counter and Flag";
        default:
            return nullptr;  // reserved (Annex A)
    }
}

bool diagnostics_echoes(std::uint16_t sub) {
    return sub == 0x00 || sub == 0x01 || sub == 0x03 || sub == 0x04 || sub == 0x0A || sub == 0x14;
}

// One data word reads best as a word; anything else (00 takes any length) as bytes.
std::string diagnostics_data_text(Bytes b) {
    if (b.size() == 2) return fmt::format("0x{:04X}", (b[0] << 8) | b[1]);
    return data_bytes_text(b);
}

void diagnostics(Decoder& d) {
    const auto sub = u16_at(d.data, 0);
    if (!sub) {
        d.expect_header(3);
        return;
    }
    const Bytes payload = slice(d.data, 2);
    const char* name = diagnostics_name(*sub);
    d.out.summary = name ? std::string(name) : fmt::format("sub-function 0x{:04X}", *sub);
    if (!payload.empty()) d.out.summary += " " + diagnostics_data_text(payload);
    if (!name) {
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
        } else if (asked && diagnostics_echoes(*sub)) {
            const Bytes asked_data = slice(d.req, 2);
            if (!std::equal(payload.begin(), payload.end(), asked_data.begin(), asked_data.end())) {
                d.note(note_id::request_mismatch, fmt::format("echo differs from the request ({})",
                                                              diagnostics_data_text(asked_data)));
            }
        }
    }
}

// ---------------------------------------------------------------------------------
// 6.14 Read File Record (14), request
//
//   +----+------------+----------------------------------------------+
//   | fc | byte count | sub-requests, 7 bytes each:                   |
//   |    | 07..F5     | ref type 06 | file | record | record length    |
//   +----+------------+----------------------------------------------+
//     1        1              1        2      2          2

struct FileRecord {
    std::uint16_t file = 0;
    std::uint16_t record = 0;
    std::uint16_t length = 0;  // in registers
};

std::string file_record_text(const FileRecord& r) {
    return fmt::format("file {} record 0x{:04X} x{}", r.file, r.record, r.length);
}

// Checks shared by the sub-requests of 14 and 15; `notes` is null for a request that
// is only read to explain its answer (its problems were reported on its own frame).
void check_file_reference(Notes* notes, std::size_t index, std::uint8_t type, const FileRecord& r) {
    if (notes == nullptr) return;
    if (type != kFileReferenceType) {
        notes->push_back({note_id::illegal_value,
                          fmt::format("sub-request {}: reference type 0x{:02X}, 0x06 required",
                                      index + 1, type)});
    }
    if (r.file == 0) {
        notes->push_back(
            {note_id::illegal_value, fmt::format("sub-request {}: file number 0", index + 1)});
    }
    if (r.record > kMaxFileRecord) {
        notes->push_back({note_id::illegal_value,
                          fmt::format("sub-request {}: record number 0x{:04X} above 0x270F",
                                      index + 1, r.record)});
    }
}

std::vector<FileRecord> read_file_sub_requests(Bytes groups, Notes* notes) {
    constexpr std::size_t kGroup = 7;
    std::vector<FileRecord> records;
    for (std::size_t at = 0; at < groups.size(); at += kGroup) {
        const Bytes g = slice(groups, at, kGroup);
        if (g.size() < kGroup) {
            if (notes != nullptr) {
                notes->push_back(
                    {note_id::malformed, fmt::format("sub-request {} cut short: {} of 7 bytes",
                                                     records.size() + 1, g.size())});
            }
            break;
        }
        const FileRecord r{*u16_at(g, 1), *u16_at(g, 3), *u16_at(g, 5)};
        check_file_reference(notes, records.size(), g[0], r);
        records.push_back(r);
    }
    return records;
}

void read_file_request(Decoder& d) {
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
    std::vector<std::string> parts;
    parts.reserve(records.size());
    for (const FileRecord& r : records) parts.push_back(file_record_text(r));
    d.out.summary = counted(records.size(), "sub-request", "sub-requests");
    if (!parts.empty()) d.out.summary += ": " + join(parts, ", ");
}

// 6.14 response
//
//   +----+------------+---------------------------------------------+
//   | fc | byte count | sub-responses:                               |
//   |    |            | length | ref type 06 | record data           |
//   +----+------------+---------------------------------------------+
//     1        1          1          1        length - 1 (2 per register)

void read_file_response(Decoder& d) {
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
    std::vector<std::string> parts;
    std::size_t at = 0;
    while (at < groups.size()) {
        const std::size_t index = parts.size();
        const std::uint8_t length = groups[at];
        const Bytes group = slice(groups, at + 1, length);
        if (group.size() < length) {
            d.note(note_id::malformed,
                   fmt::format("sub-response {} cut short: {} bytes announced, {} present",
                               index + 1, length, group.size()));
        }
        if (length % 2 == 0) {
            d.note(note_id::malformed,
                   fmt::format("sub-response {}: length {}, 1 + 2 per register expected", index + 1,
                               length));
        }
        if (const auto type = u8_at(group, 0); type && *type != kFileReferenceType) {
            d.note(note_id::illegal_value,
                   fmt::format("sub-response {}: reference type 0x{:02X}, 0x06 required", index + 1,
                               *type));
        }
        const std::vector<std::uint16_t> values = words_of(slice(group, 1));
        std::string text = word_list(values);
        if (index < asked.size()) {
            std::string described = file_record_text(asked[index]);
            if (!values.empty()) described += ": ";
            text = described.append(text);
            if (length != 1U + 2U * asked[index].length) {
                d.note(note_id::byte_count_mismatch,
                       fmt::format("sub-response {}: length {}, {} asked need {}", index + 1,
                                   length, counted(asked[index].length, "register", "registers"),
                                   1U + 2U * asked[index].length));
            }
        }
        parts.push_back(std::move(text));
        at += 1U + length;
    }
    if (d.has_request && parts.size() != asked.size()) {
        d.note(note_id::request_mismatch,
               fmt::format("{}, {} asked", counted(parts.size(), "sub-response", "sub-responses"),
                           asked.size()));
    }
    d.out.summary = counted(parts.size(), "sub-response", "sub-responses");
    if (!parts.empty()) d.out.summary += ": " + join(parts, ", ");
}

// ---------------------------------------------------------------------------------
// 6.15 Write File Record (15), request and its echo
//
//   +----+------------+-------------------------------------------------------------+
//   | fc | byte count | sub-requests:                                                |
//   |    | 09..FB     | ref type 06 | file | record | record length | record data    |
//   +----+------------+-------------------------------------------------------------+
//     1        1            1         2      2          2          2 x record length

void write_file_record(Decoder& d) {
    const auto count = u8_at(d.data, 0);
    if (!count) {
        d.expect_header(2);
        return;
    }
    const Bytes groups = d.counted_part(*count, slice(d.data, 1));
    if (*count < 0x09 || *count > 0xFB) {
        d.note(note_id::illegal_value, fmt::format("byte count {} out of range 9..251", *count));
    }
    std::vector<std::string> parts;
    std::size_t at = 0;
    while (at < groups.size()) {
        const std::size_t index = parts.size();
        const Bytes header = slice(groups, at, 7);
        if (header.size() < 7) {
            d.note(note_id::malformed, fmt::format("sub-request {} cut short: {} of 7 bytes",
                                                   index + 1, header.size()));
            break;
        }
        const FileRecord r{*u16_at(header, 1), *u16_at(header, 3), *u16_at(header, 5)};
        check_file_reference(&d.out.notes, index, header[0], r);
        const std::vector<std::uint16_t> values =
            words_of(slice(groups, at + 7, 2U * std::size_t{r.length}));
        if (values.size() < r.length) {
            d.note(note_id::malformed,
                   fmt::format("sub-request {} cut short: {} announced, {} present", index + 1,
                               counted(r.length, "register", "registers"), values.size()));
        }
        std::string text = file_record_text(r);
        if (!values.empty()) text += ": " + word_list(values);
        parts.push_back(std::move(text));
        at += 7U + 2U * std::size_t{r.length};
    }
    d.out.summary = counted(parts.size(), "sub-request", "sub-requests");
    if (!parts.empty()) d.out.summary += ": " + join(parts, ", ");
    if (d.is_response() && d.has_request &&
        !std::equal(d.data.begin(), d.data.end(), d.req.begin(), d.req.end())) {
        d.note(note_id::request_mismatch, "echo differs from the request");
    }
}

// ---------------------------------------------------------------------------------
// 6.19 Encapsulated Interface Transport (2B); 6.21 Read Device Identification (MEI 0E)
//
//   request   +----+----+--------------------+-----------+
//             | 2B | 0E | read device id code | object id |
//             +----+----+--------------------+-----------+
//   response  +----+----+------+-------------+---------+-----------+---------+---------+
//             | 2B | 0E | code | conformity  | more    | next obj  | count   | objects |
//             +----+----+------+-------------+---------+-----------+---------+---------+
//   object    | id | length | value (length bytes) |
// 6.20 CANopen General Reference (MEI 0D) has no layout of its own: shown as bytes.

constexpr std::uint8_t kMeiCanopen = 0x0D;
constexpr std::uint8_t kMeiDeviceId = 0x0E;

const char* device_id_code_name(std::uint8_t code) {
    switch (code) {
        case 0x01:
            return "basic";
        case 0x02:
            return "regular";
        case 0x03:
            return "extended";
        case 0x04:
            return "specific";
        default:
            return nullptr;
    }
}

std::string device_id_code_text(std::uint8_t code) {
    const char* name = device_id_code_name(code);
    return name ? std::string(name) : fmt::format("code 0x{:02X}", code);
}

const char* device_object_name(std::uint8_t id) {
    switch (id) {
        case 0x00:
            return "VendorName";
        case 0x01:
            return "ProductCode";
        case 0x02:
            return "MajorMinorRevision";
        case 0x03:
            return "VendorUrl";
        case 0x04:
            return "ProductName";
        case 0x05:
            return "ModelName";
        case 0x06:
            return "UserApplicationName";
        default:
            return nullptr;  // 07..7F reserved, 80..FF private
    }
}

bool valid_conformity(std::uint8_t level) {
    return level == 0x01 || level == 0x02 || level == 0x03 || level == 0x81 || level == 0x82 ||
           level == 0x83;
}

void device_id_request(Decoder& d) {
    d.expect_size(4);
    const auto code = u8_at(d.data, 1);
    const auto object = u8_at(d.data, 2);
    std::vector<std::string> parts;
    if (code) parts.push_back(device_id_code_text(*code));
    if (object) parts.push_back(fmt::format("object 0x{:02X}", *object));
    d.out.summary = join(parts, ", ");
    if (code && !device_id_code_name(*code)) {
        d.note(note_id::illegal_value,
               fmt::format("read device id code 0x{:02X} out of range 1..4", *code));
    }
}

void device_id_response(Decoder& d) {
    const auto code = u8_at(d.data, 1);
    const auto conformity = u8_at(d.data, 2);
    const auto more = u8_at(d.data, 3);
    const auto next = u8_at(d.data, 4);
    const auto count = u8_at(d.data, 5);
    d.expect_header(7);

    std::vector<std::string> parts;
    if (code) parts.push_back(device_id_code_text(*code));
    if (conformity) parts.push_back(fmt::format("conformity 0x{:02X}", *conformity));
    if (more) parts.push_back(fmt::format("more 0x{:02X}", *more));
    if (next) parts.push_back(fmt::format("next 0x{:02X}", *next));
    if (code && !device_id_code_name(*code)) {
        d.note(note_id::illegal_value,
               fmt::format("read device id code 0x{:02X} out of range 1..4", *code));
    }
    if (conformity && !valid_conformity(*conformity)) {
        d.note(note_id::illegal_value, fmt::format("conformity level 0x{:02X}", *conformity));
    }
    if (more && *more != 0x00 && *more != 0xFF) {
        d.note(note_id::illegal_value,
               fmt::format("more follows 0x{:02X}, 0x00 or 0xFF expected", *more));
    }
    if (d.has_request && code) {
        const auto asked = u8_at(d.req, 1);
        if (asked && *asked != *code) {
            d.note(note_id::request_mismatch,
                   fmt::format("request was {}", device_id_code_text(*asked)));
        }
    }
    if (count) {
        std::vector<std::string> objects;
        std::size_t at = 6;
        while (objects.size() < *count && at < d.data.size()) {
            const std::uint8_t id = d.data[at];
            const auto length = u8_at(d.data, at + 1);
            const Bytes value = length ? slice(d.data, at + 2, *length) : Bytes{};
            const char* name = device_object_name(id);
            objects.push_back(
                fmt::format("{}={}", name ? std::string(name) : fmt::format("object 0x{:02X}", id),
                            quoted(value)));
            if (!length || value.size() < *length) {
                d.note(note_id::malformed,
                       fmt::format("object 0x{:02X} cut short: {} bytes announced, {} present", id,
                                   length ? *length : 0, value.size()));
            }
            at += 2U + (length ? std::size_t{*length} : 0U);
        }
        if (objects.size() < *count) {
            d.note(note_id::malformed,
                   fmt::format("{} announced, {} present", counted(*count, "object", "objects"),
                               objects.size()));
        }
        if (at < d.data.size()) {
            d.note(note_id::malformed, fmt::format("{} after the last object",
                                                   counted(d.data.size() - at, "byte", "bytes")));
        }
        std::string list = counted(objects.size(), "object", "objects");
        if (!objects.empty()) list += ": " + join(objects, ", ");
        parts.push_back(std::move(list));
    }
    d.out.summary = join(parts, ", ");
}

void encapsulated_interface(Decoder& d) {
    const auto mei = u8_at(d.data, 0);
    if (!mei) {
        d.expect_header(2);
        return;
    }
    if (*mei == kMeiDeviceId) {
        d.out.function_name = "Read Device Identification";
        if (d.is_response()) {
            device_id_response(d);
        } else {
            device_id_request(d);
        }
        return;
    }
    const Bytes rest = slice(d.data, 1);
    d.out.summary = *mei == kMeiCanopen ? std::string("CANopen General Reference")
                                        : fmt::format("MEI type 0x{:02X}", *mei);
    if (!rest.empty()) d.out.summary += ": " + data_bytes_text(rest);
    if (*mei != kMeiCanopen) {
        d.note(note_id::unknown_function, fmt::format("reserved MEI type 0x{:02X}", *mei));
    }
}

// ---------------------------------------------------------------------------------
// Section 7: exception response, fc | 0x80 followed by one exception code.

void exception_response(Decoder& d) {
    d.out.exception = true;
    // An exception to a 2B/0E request is about Read Device Identification.
    if (d.has_request && (d.fc & 0x7FU) == 0x2B && u8_at(d.req, 0) == kMeiDeviceId) {
        d.out.function_name = "Read Device Identification";
    }
    const auto code = u8_at(d.data, 0);
    if (!code) {
        d.out.summary = "exception";
        d.note(note_id::malformed, "exception code missing");
        return;
    }
    d.expect_size(2);
    d.out.exception_code = *code;
    const char* name = exception_name(*code);
    const std::string_view text = name ? name : "unknown exception code";
    append_written(d.out.summary, 10 + 2 + 1 + text.size(), [&](char* p) {
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

// Function codes without a public layout: the data as bytes (section 5 and Annex A).
void unknown_function(Decoder& d) {
    d.out.summary = data_bytes_text(d.data);
    const unsigned fc = d.fc;
    std::string why;
    if ((fc >= 0x41 && fc <= 0x48) || (fc >= 0x64 && fc <= 0x6E)) {
        why = fmt::format("user-defined function code 0x{:02X}", fc);
    } else if (fc == 0x09 || fc == 0x0A || fc == 0x0D || fc == 0x0E || fc == 0x29 || fc == 0x2A ||
               fc == 0x5A || fc == 0x5B || fc == 0x7D || fc == 0x7E || fc == 0x7F) {
        why = fmt::format("reserved function code 0x{:02X}", fc);
    } else {
        why = fmt::format("function code 0x{:02X} is not defined by the specification", fc);
    }
    d.note(note_id::unknown_function, std::move(why));
}

void decode_function(Decoder& d) {
    const bool response = d.is_response();
    switch (d.fc) {
        case 0x01:
            if (response) return read_bits_response(d, DataTable::coils, "coil", "coils");
            return read_request(d, kMaxReadBits);
        case 0x02:
            if (response) {
                return read_bits_response(d, DataTable::discrete_inputs, "input", "inputs");
            }
            return read_request(d, kMaxReadBits);
        case 0x03:
            if (response) return read_registers_response(d, DataTable::holding_registers);
            return read_request(d, kMaxReadRegisters);
        case 0x04:
            if (response) return read_registers_response(d, DataTable::input_registers);
            return read_request(d, kMaxReadRegisters);
        case 0x05:
            return write_single_coil(d);
        case 0x06:
            return write_single_register(d);
        case 0x07:
            if (response) return read_exception_status_response(d);
            return bare_request(d);
        case 0x08:
            return diagnostics(d);
        case 0x0B:
            if (response) return comm_event_counter_response(d);
            return bare_request(d);
        case 0x0C:
            if (response) return comm_event_log_response(d);
            return bare_request(d);
        case 0x0F:
            if (response) return write_multiple_response(d, true);
            return write_multiple_request(d, true);
        case 0x10:
            if (response) return write_multiple_response(d, false);
            return write_multiple_request(d, false);
        case 0x11:
            if (response) return report_server_id_response(d);
            return bare_request(d);
        case 0x14:
            if (response) return read_file_response(d);
            return read_file_request(d);
        case 0x15:
            return write_file_record(d);
        case 0x16:
            return mask_write_register(d);
        case 0x17:
            if (response) return read_registers_response(d, DataTable::holding_registers);
            return read_write_request(d);
        case 0x18:
            if (response) return read_fifo_response(d);
            return read_fifo_request(d);
        case 0x2B:
            return encapsulated_interface(d);
        default:
            return unknown_function(d);
    }
}

}  // namespace

namespace {

// Kept out of clear(), which runs twice for every record and seldom gets here: inlined,
// they made every call save and restore registers for them.
[[gnu::noinline]] void clear_notes(Notes& notes) {
    notes.clear();
}

[[gnu::noinline]] void keep_blocks_as_spares(DecodedPdu& pdu) {
    for (DataBlock& block : pdu.blocks) pdu.spare_blocks.push_back(std::move(block));
    pdu.blocks.clear();
}

}  // namespace

void DecodedPdu::clear() {
    function_name.clear();
    summary.clear();
    exception = false;
    exception_code = 0;
    if (!notes.empty()) clear_notes(notes);
    // Usually the spares are empty (add_block took them): then the lists change places.
    // A record is cleared twice (when it is reused, and when it is decoded into): the
    // second time there is nothing to keep.
    if (blocks.empty()) return;
    if (spare_blocks.empty()) {
        spare_blocks.swap(blocks);
        return;
    }
    keep_blocks_as_spares(*this);
}

DecodedPdu decode_pdu(std::span<const std::uint8_t> pdu, Role role,
                      std::span<const std::uint8_t> request_pdu) {
    DecodedPdu out;
    decode_pdu(pdu, role, request_pdu, out);
    return out;
}

void decode_pdu(std::span<const std::uint8_t> pdu, Role role,
                std::span<const std::uint8_t> request_pdu, DecodedPdu& out) {
    out.clear();
    Decoder d(out);
    d.pdu = pdu;
    d.role = role;
    if (pdu.empty()) {
        d.note(note_id::malformed, "empty PDU: no function code");
        return;
    }
    d.fc = pdu[0];
    d.data = pdu.subspan(1);
    append_function_name(out.function_name, d.fc);
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
        exception_response(d);
    } else {
        decode_function(d);
    }
}

std::string data_bytes_text(std::span<const std::uint8_t> data) {
    const auto shown = data.first(std::min(data.size(), kMaxPduDataShown));
    std::string text;
    append_hex(text, shown, true);
    if (shown.size() < data.size()) {
        text += fmt::format(" ... (+{} more)", data.size() - shown.size());
    }
    return text;
}

std::string function_name(std::uint8_t function) {
    std::string name;
    append_function_name(name, function);
    return name;
}

void append_function_name(std::string& out, std::uint8_t function) {
    const std::string_view name = kFunctionNames[function & 0x7FU];
    if (!name.empty()) {
        out.append(name.data(), name.size());
        return;
    }
    const auto fc = static_cast<std::uint8_t>(function & 0x7FU);
    append_written(out, 11 + 2, [&](char* p) {
        p = write_text(p, "Function 0x");
        return write_hex(p, std::span(&fc, 1), false);
    });
}

const char* standard_function_name(std::uint8_t function) {
    return standard_name(function);
}

const char* exception_name(std::uint8_t code) {
    // Section 7, "MODBUS Exception Codes".
    switch (code) {
        case 0x01:
            return "Illegal Function";
        case 0x02:
            return "Illegal Data Address";
        case 0x03:
            return "Illegal Data Value";
        case 0x04:
            return "Server Device Failure";
        case 0x05:
            return "Acknowledge";
        case 0x06:
            return "Server Device Busy";
        case 0x07:
            return "Negative Acknowledge";
        case 0x08:
            return "Memory Parity Error";
        case 0x0A:
            return "Gateway Path Unavailable";
        case 0x0B:
            return "Gateway Target Device Failed to Respond";
        default:
            return nullptr;
    }
}

}  // namespace rtuscope
