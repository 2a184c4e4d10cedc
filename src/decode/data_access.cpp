// Data access (section 5.1): reading and writing coils, discrete inputs, holding and input
// registers, section 6.1-6.6, 6.11, 6.12, 6.16-6.18. The limits each request checks are its
// function table entry's (max_quantity).
#include <fmt/format.h>

#include "decode/pdu_decoders.hpp"
#include "decode/pdu_decoding.hpp"
#include "util/text.hpp"

namespace rtuscope {
namespace {

constexpr std::uint16_t kMaxReadWriteWrite = 121;  // 6.17 write part
constexpr std::uint16_t kCoilOn = 0xFF00;          // 6.5
constexpr std::uint16_t kCoilOff = 0x0000;

// What a bit of the function's table is called: "coil", "input".
std::string_view bit_name(const PduDecoding& d, bool many) {
    if (d.spec.table == DataTable::discrete_inputs) return many ? "inputs" : "input";
    return many ? "coils" : "coil";
}

}  // namespace

// ---------------------------------------------------------------------------------
// 6.1 Read Coils (01), 6.2 Read Discrete Inputs (02), 6.3 Read Holding Registers (03),
// 6.4 Read Input Registers (04): requests
//
//   +----+---------------+----------+
//   | fc | start address | quantity |
//   +----+---------------+----------+
//     1         2             2

void decode_read_request(PduDecoding& d) {
    d.expect_size(5);
    const auto start = u16_at(d.data, 0);
    const auto qty = u16_at(d.data, 2);
    append_range(d.out.summary, start, qty);
    if (qty) d.check_quantity(*qty, d.spec.max_quantity);
    if (start && qty) d.check_range(*start, *qty);
}

// 6.1 / 6.2 responses: the bits packed eight to a byte, first address in the LSB.
//
//   +----+------------+----------------------+
//   | fc | byte count | bits, padded with 0  |
//   +----+------------+----------------------+
//     1        1          byte count

void decode_read_bits_response(PduDecoding& d) {
    const auto count = u8_at(d.data, 0);
    if (!count) {
        d.expect_header(2);
        return;
    }
    const Bytes bytes = d.counted_part(*count, slice(d.data, 1));
    const auto asked = d.asked_range();
    if (asked) {
        const std::size_t need = (std::size_t{asked->qty} + 7) / 8;
        if (*count != need) {
            d.note(note_id::byte_count_mismatch,
                   fmt::format("byte count {}, {} {} asked need {}", *count, asked->qty,
                               bit_name(d, asked->qty != 1), need));
        }
    }
    // Without the request the padding cannot be told from data: show every bit.
    const std::size_t n = asked ? std::size_t{asked->qty} : bytes.size() * 8;
    DataBlock& block = d.add_block(d.spec.table, asked ? asked->start : 0, false);
    bits_of(bytes, n, block.values);
    append_listed(d.out.summary, block.values, bit_name(d, false), bit_name(d, true), true);
    if (!asked || block.values.empty()) d.drop_last_block();
}

// 6.3 / 6.4 / 6.17 responses: registers, two bytes each.
//
//   +----+------------+--------------------------+
//   | fc | byte count | registers (2 bytes each) |
//   +----+------------+--------------------------+
//     1        1           byte count

void decode_read_registers_response(PduDecoding& d) {
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
    const auto asked = d.asked_range();  // 6.17 also starts with the read range
    if (asked && *count != 2U * asked->qty) {
        d.note(note_id::byte_count_mismatch,
               fmt::format("byte count {}, {} {} asked need {}", *count, asked->qty,
                           plural(asked->qty, "register", "registers"), 2U * asked->qty));
    }
    DataBlock& block = d.add_block(d.spec.table, asked ? asked->start : 0, false);
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

namespace {

// "0x00AC ON"
void append_single_coil(std::string& out, Bytes b) {
    const auto address = u16_at(b, 0);
    const auto value = u16_at(b, 2);
    append_with(out, 6 + 1 + 6, [&](char* p) {
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

// "0x0001 = 0x0003 (3)"
void append_single_register(std::string& out, Bytes b) {
    const auto address = u16_at(b, 0);
    const auto value = u16_at(b, 2);
    append_with(out, 6 + 3 + 6 + 2 + 5 + 1, [&](char* p) {
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

// "0x0004 AND 0x00F2 OR 0x0025"
void append_mask_write(std::string& out, Bytes b) {
    const auto address = u16_at(b, 0);
    const auto and_mask = u16_at(b, 2);
    const auto or_mask = u16_at(b, 4);
    if (address) fmt::format_to(std::back_inserter(out), "0x{:04X}", *address);
    if (and_mask) {
        append_separator(out, " ");
        fmt::format_to(std::back_inserter(out), "AND 0x{:04X}", *and_mask);
    }
    if (or_mask) {
        append_separator(out, " ");
        fmt::format_to(std::back_inserter(out), "OR 0x{:04X}", *or_mask);
    }
}

}  // namespace

void decode_write_single_coil(PduDecoding& d) {
    d.expect_size(5);
    const auto address = u16_at(d.data, 0);
    const auto value = u16_at(d.data, 2);
    append_single_coil(d.out.summary, d.data);
    if (value && *value != kCoilOn && *value != kCoilOff) {
        d.note(note_id::illegal_value,
               fmt::format("coil value 0x{:04X}, 0xFF00 or 0x0000 expected", *value));
    } else if (address && value) {
        d.add_block(DataTable::coils, *address, true)
            .values.assign(1, static_cast<std::uint16_t>(*value == kCoilOn));
    }
    if (d.is_response()) d.check_echo(4, append_single_coil);
}

// 6.6 Write Single Register (06), request and echo
//
//   +----+---------+-------+
//   | fc | address | value |
//   +----+---------+-------+
//     1       2        2

void decode_write_single_register(PduDecoding& d) {
    d.expect_size(5);
    const auto address = u16_at(d.data, 0);
    const auto value = u16_at(d.data, 2);
    append_single_register(d.out.summary, d.data);
    if (address && value) {
        d.add_block(DataTable::holding_registers, *address, true).values.assign(1, *value);
    }
    if (d.is_response()) d.check_echo(4, append_single_register);
}

// ---------------------------------------------------------------------------------
// 6.11 Write Multiple Coils (0F), 6.12 Write Multiple Registers (10): requests
//
//   +----+---------------+----------+------------+-----------------+
//   | fc | start address | quantity | byte count | values          |
//   +----+---------------+----------+------------+-----------------+
//     1         2             2           1        byte count

void decode_write_multiple_request(PduDecoding& d) {
    const bool bits = d.spec.table == DataTable::coils;
    d.expect_header(6);
    const auto start = u16_at(d.data, 0);
    const auto qty = u16_at(d.data, 2);
    const auto count = u8_at(d.data, 4);
    append_range(d.out.summary, start, qty);
    if (qty) d.check_quantity(*qty, d.spec.max_quantity);
    if (start && qty) d.check_range(*start, *qty);
    if (!count) return;

    const Bytes bytes = d.counted_part(*count, slice(d.data, 5));
    if (qty) {
        const std::size_t asked = *qty;
        const std::size_t need = bits ? (asked + 7) / 8 : 2 * asked;
        if (*count != need) {
            d.note(note_id::byte_count_mismatch,
                   fmt::format(
                       "byte count {}, {} {} need {}", *count, *qty,
                       bits ? plural(*qty, "coil", "coils") : plural(*qty, "register", "registers"),
                       need));
        }
    }
    DataBlock& block = d.add_block(d.spec.table, start.value_or(0), true);
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

void decode_write_multiple_response(PduDecoding& d) {
    d.expect_size(5);
    const auto start = u16_at(d.data, 0);
    const auto qty = u16_at(d.data, 2);
    append_range(d.out.summary, start, qty);
    if (qty) d.check_quantity(*qty, d.spec.max_quantity);
    if (const auto asked = d.asked_range();
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

void decode_mask_write_register(PduDecoding& d) {
    d.expect_size(7);
    append_mask_write(d.out.summary, d.data);
    if (d.is_response()) d.check_echo(6, append_mask_write);
}

// ---------------------------------------------------------------------------------
// 6.17 Read/Write Multiple Registers (17), request; the write happens before the read.
//
//   +----+------------+----------+-------------+-----------+-------+--------------+
//   | fc | read start | read qty | write start | write qty | count | write values |
//   +----+------------+----------+-------------+-----------+-------+--------------+
//     1        2           2           2            2         1      byte count

void decode_read_write_request(PduDecoding& d) {
    d.expect_header(10);
    const auto read_start = u16_at(d.data, 0);
    const auto read_qty = u16_at(d.data, 2);
    const auto write_start = u16_at(d.data, 4);
    const auto write_qty = u16_at(d.data, 6);
    const auto count = u8_at(d.data, 8);

    std::string& s = d.out.summary;
    if (read_start || read_qty) {
        s += "read ";
        append_range(s, read_start, read_qty);
    }
    if (write_start || write_qty) {
        s += ", write ";
        append_range(s, write_start, write_qty);
    }
    if (read_qty) d.check_quantity(*read_qty, d.spec.max_quantity, "read quantity");
    if (read_start && read_qty) d.check_range(*read_start, *read_qty);
    if (write_qty) d.check_quantity(*write_qty, kMaxReadWriteWrite, "write quantity");
    if (write_start && write_qty) d.check_range(*write_start, *write_qty);
    if (!count) return;
    const Bytes bytes = d.counted_part(*count, slice(d.data, 9));
    if (write_qty && *count != 2U * *write_qty) {
        d.note(note_id::byte_count_mismatch,
               fmt::format("byte count {}, {} {} need {}", *count, *write_qty,
                           plural(*write_qty, "register", "registers"), 2U * *write_qty));
    }
    DataBlock& block = d.add_block(DataTable::holding_registers, write_start.value_or(0), true);
    words_of(bytes, block.values);
    append_values(s, block.values, false);
    if (!write_start || block.values.empty()) d.drop_last_block();
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

void decode_read_fifo_request(PduDecoding& d) {
    d.expect_size(3);
    if (const auto address = u16_at(d.data, 0)) {
        fmt::format_to(std::back_inserter(d.out.summary), "FIFO 0x{:04X}", *address);
    }
}

void decode_read_fifo_response(PduDecoding& d) {
    const auto count = u16_at(d.data, 0);
    const auto fifo_count = u16_at(d.data, 2);
    if (!d.expect_header(5) && !count) return;
    Bytes covered;
    if (count) covered = d.counted_part(*count, slice(d.data, 2));
    if (fifo_count) {
        if (*fifo_count > d.spec.max_quantity) {
            d.note(note_id::illegal_value,
                   fmt::format("FIFO count {}, at most {}", *fifo_count, d.spec.max_quantity));
        }
        if (count && *count != 2U + 2U * *fifo_count) {
            d.note(note_id::byte_count_mismatch,
                   fmt::format("byte count {}, {} {} need {}", *count, *fifo_count,
                               plural(*fifo_count, "value", "values"), 2U + 2U * *fifo_count));
        }
    }
    std::vector<std::uint16_t> values;
    words_of(slice(covered, 2), values);
    append_listed(d.out.summary, values, "value", "values", false);
}

}  // namespace rtuscope
