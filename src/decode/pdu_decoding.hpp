// What the decoders of the function codes share: the PDU being decoded with bounds-checked
// reads, the checks of the specification's common rules, and the data blocks they fill.
//
// A PDU is the function code followed by its data; multi-byte fields are big-endian:
//
//   +----------+-------------------------------+
//   | function | data (0..252 bytes)           |
//   +----------+-------------------------------+
//   | fc|0x80  | exception code                |   exception response (section 7)
//   +----------+-------------------------------+
//
// The bytes come off a wire we do not control. Every read goes through u8_at / u16_at /
// slice; a PDU that is cut short or too long is decoded as far as its bytes go and the
// problem becomes a Note, so decoding never throws and never stops.
#pragma once

#include <fmt/format.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "decode/decoder.hpp"
#include "decode/pdu_text.hpp"

namespace rtuscope {

using Bytes = std::span<const std::uint8_t>;

inline std::optional<std::uint8_t> u8_at(Bytes b, std::size_t at) {
    if (at >= b.size()) return std::nullopt;
    return b[at];
}

inline std::optional<std::uint16_t> u16_at(Bytes b, std::size_t at) {
    if (at >= b.size() || b.size() - at < 2) return std::nullopt;
    return static_cast<std::uint16_t>((b[at] << 8) | b[at + 1]);
}

// At most `n` bytes of `b` from `at`; empty when `at` is past the end.
inline Bytes slice(Bytes b, std::size_t at,
                   std::size_t n = std::numeric_limits<std::size_t>::max()) {
    if (at >= b.size()) return {};
    return b.subspan(at, std::min(n, b.size() - at));
}

// A start address and a quantity, as reads and multiple writes begin.
struct Range {
    std::uint16_t start = 0;
    std::uint16_t qty = 0;
};

inline std::optional<Range> range_at(Bytes b, std::size_t at) {
    const auto start = u16_at(b, at);
    const auto qty = u16_at(b, at + 2);
    if (!start || !qty) return std::nullopt;
    return Range{*start, *qty};
}

struct PduDecoding {
    PduDecoding(const FunctionSpec& function, DecodedPdu& pdu_out) : spec(function), out(pdu_out) {}

    const FunctionSpec& spec;
    std::uint8_t fc = 0;
    Role role = Role::request;
    Bytes pdu;
    Bytes data;  // the PDU without its function code
    Bytes req;   // data of the request this answers (without function code)
    bool has_request = false;
    DecodedPdu& out;

    void note(const char* id, std::string_view text) { out.notes.add(id, text); }

    [[nodiscard]] bool is_response() const { return role == Role::response; }

    // The request this frame answers, when it is known and starts with a range.
    [[nodiscard]] std::optional<Range> asked_range() const {
        return has_request ? range_at(req, 0) : std::nullopt;
    }

    // A layout of exactly `n` PDU bytes, function code included.
    void expect_size(std::size_t n) {
        if (pdu.size() != n) note_size(n);
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
        if (following.size() != count) note_count(count, following.size());
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

    // An answer that repeats the first `n` data bytes of its request (05, 06, 16, ...);
    // `describe(text, bytes)` appends what the request was when it does not.
    template <typename Describe>
    void check_echo(std::size_t n, Describe describe) {
        if (!has_request || req.size() < n || data.size() < n) return;
        if (!std::equal(data.begin(), data.begin() + static_cast<std::ptrdiff_t>(n), req.begin())) {
            std::string text = "request was ";
            describe(text, req);
            note(note_id::request_mismatch, text);
        }
    }

    // A data block for the profile layer (its buffers are an earlier record's).
    DataBlock& add_block(DataTable table, std::uint16_t start, bool write) {
        DataBlock& block = out.blocks.add();
        block.table = table;
        block.start = start;
        block.write = write;
        return block;
    }

    // Takes back the block just added (it turned out to carry nothing to explain).
    void drop_last_block() { out.blocks.pop_back(); }

  private:
    void note_size(std::size_t n);
    void note_count(std::size_t count, std::size_t present);
};

}  // namespace rtuscope
