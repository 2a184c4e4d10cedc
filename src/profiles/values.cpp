// Register values in the device's own words: the raw words of a DataBlock explained with
// a Profile (names, scales, units, enum labels, bit names, strings), with value.* notes
// for what does not fit. Like the decoder, this never throws and never reads outside
// the block, whatever the block or the profile holds: captures are full of surprises and
// profiles are written by hand.
#include "profiles/values.hpp"

#include <fmt/compile.h>
#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstddef>
#include <limits>
#include <span>
#include <string_view>

#include "util/text.hpp"

namespace rtuscope {

namespace {

using Words = std::span<const std::uint16_t>;

// Anything a profile could ask for beyond this is a typo, not a wish for 10^9 digits.
constexpr int kMaxDecimals = 30;

bool is_integer_type(ValueType type) {
    return type == ValueType::u16 || type == ValueType::i16 || type == ValueType::u32 ||
           type == ValueType::i32 || type == ValueType::u64 || type == ValueType::i64;
}

// Each value of a device read shows its words and its number: written directly, not
// through format strings, which would be most of the cost of decoding with a profile. They
// are appended to the value's own (emptied) strings, whose buffers are reused record
// after record (reused_list.hpp).
void append_hex_words(std::string& out, Words words) {
    append_with(out, 7 * words.size(), [&](char* p) {
        for (std::size_t i = 0; i < words.size(); ++i) {
            if (i > 0) *p++ = ' ';
            p = write_hex4(p, words[i]);
        }
        return p;
    });
}

void append_decimal(std::string& out, std::int64_t value) {
    const fmt::format_int text(value);
    out.append(text.data(), text.size());
}

// raw / 10^decimals written exactly: the digits of raw with a decimal point put in
// ("2205", 1 -> "220.5"; "-5", 2 -> "-0.05"). For |raw| < 2^51 that is what fmt's
// "{:.{decimals}f}" prints for the double raw * 10^-decimals, which lies within
// |raw| * 10^-decimals * 2^-52 of the exact value, far inside half a unit of the last
// decimal; and it costs a fraction of formatting the double.
void append_shifted_decimal(std::string& out, std::int64_t raw, int decimals) {
    const std::uint64_t magnitude = raw < 0 ? std::uint64_t{0} - static_cast<std::uint64_t>(raw)
                                            : static_cast<std::uint64_t>(raw);
    const fmt::format_int text(magnitude);
    const std::string_view digits(text.data(), text.size());
    const auto d = static_cast<std::size_t>(decimals);
    if (raw < 0) out += '-';
    if (digits.size() <= d) {
        out += "0.";
        out.append(d - digits.size(), '0');
        out += digits;
    } else {
        out += digits.substr(0, digits.size() - d);
        if (d > 0) {
            out += '.';
            out += digits.substr(digits.size() - d);
        }
    }
}

const char* bit_text(std::uint16_t item) {
    return item != 0 ? "1" : "0";
}

// fmt prints IEEE negative zero as "-0" / "-0.0", which reads like a sign error.
// `from`: where the number starts in `text`.
void drop_negative_zero(std::string& text, std::size_t from) {
    if (text.size() > from + 1 && text[from] == '-' &&
        text.find_first_not_of("0.", from + 1) == std::string::npos) {
        text.erase(from, 1);
    }
}

// The fewest decimals that show every multiple of `scale` exactly (0.1 -> 1, 0.5 -> 1,
// 0.01 -> 2), so that 3 * 0.1 prints as "0.3" and not 0.30000000000000004. -1 when no
// small number of decimals does (a scale of 1/3).
int decimals_implied_by(double scale) {
    double shifted = scale;
    for (int d = 0; d <= 9; ++d, shifted *= 10) {
        const double nearest = std::round(shifted);
        if (nearest != 0 && std::abs(shifted - nearest) < 1e-9) return d;
    }
    return -1;
}

// How one register's numbers are printed. The range bounds of a note use the same style,
// so that "400.0" is flagged as "outside 0.0..300.0".
struct NumberStyle {
    enum class Kind : std::uint8_t { fixed, integer, shortest_float, shortest_double };
    Kind kind = Kind::shortest_double;
    int decimals = 0;  // for fixed
};

NumberStyle style_for(const Register& reg, bool bit_table) {
    if (reg.decimals >= 0) {
        return {NumberStyle::Kind::fixed, std::min(reg.decimals, kMaxDecimals)};
    }
    const bool integer = bit_table || is_integer_type(reg.type);
    if (integer && reg.scale == 1.0) return {NumberStyle::Kind::integer, 0};
    // A float's own digits are its precision; rounding to the scale's decimals would hide
    // digits the device sent.
    if (!bit_table && reg.type == ValueType::f32) return {NumberStyle::Kind::shortest_float, 0};
    if (!bit_table && reg.type == ValueType::f64) return {NumberStyle::Kind::shortest_double, 0};
    const int implied = decimals_implied_by(reg.scale);
    if (implied >= 0) return {NumberStyle::Kind::fixed, implied};
    return {NumberStyle::Kind::shortest_double, 0};
}

// Compiled format strings: parsing them at run time costs as much as formatting the number.
void append_number(std::string& out, double value, const NumberStyle& style) {
    const std::size_t from = out.size();
    auto to = std::back_inserter(out);
    switch (style.kind) {
        case NumberStyle::Kind::fixed:
            fmt::format_to(to, FMT_COMPILE("{:.{}f}"), value, style.decimals);
            break;
        case NumberStyle::Kind::integer:
            // Exact for register values; a fractional range bound keeps its fraction.
            if (value == std::trunc(value)) {
                fmt::format_to(to, FMT_COMPILE("{:.0f}"), value);
            } else {
                fmt::format_to(to, FMT_COMPILE("{}"), value);
            }
            break;
        case NumberStyle::Kind::shortest_float:
            fmt::format_to(to, FMT_COMPILE("{}"), static_cast<float>(value));
            break;
        case NumberStyle::Kind::shortest_double:
            fmt::format_to(to, FMT_COMPILE("{}"), value);
            break;
    }
    drop_negative_zero(out, from);
}

// A new note on the value; its text, empty, to be written.
std::string& add_note(DecodedValue& v, const char* id) {
    Note& note = v.notes.add();
    note.id = id;
    return note.text;
}

void check_range(const Register& reg, double value, const NumberStyle& style, DecodedValue& v) {
    const bool below = reg.min && value < *reg.min;
    const bool above = reg.max && value > *reg.max;
    if (!below && !above) return;
    std::string& text = add_note(v, note_id::value_out_of_range);
    if (reg.min && reg.max) {
        text += "outside ";
        append_number(text, *reg.min, style);
        text += "..";
        append_number(text, *reg.max, style);
    } else if (below) {
        text += "below ";
        append_number(text, *reg.min, style);
    } else {
        text += "above ";
        append_number(text, *reg.max, style);
    }
    if (!reg.unit.empty()) {
        text += ' ';
        text += reg.unit;
    }
}

// A number read from the wire: integers exactly, floats as sent. A u64 above the
// largest i64 is the one integer `integer` cannot hold: it keeps it in `large`.
struct RawNumber {
    enum class Kind : std::uint8_t { integer, large_unsigned, real };
    Kind kind = Kind::integer;
    std::int64_t integer = 0;
    std::uint64_t large = 0;
    double real = 0;

    static RawNumber of_integer(std::int64_t value) { return {Kind::integer, value, 0, 0}; }
    static RawNumber of_unsigned(std::uint64_t value) {
        return value > static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max())
                   ? RawNumber{Kind::large_unsigned, 0, value, 0}
                   : of_integer(static_cast<std::int64_t>(value));
    }
    static RawNumber of_real(double value) { return {Kind::real, 0, 0, value}; }

    [[nodiscard]] double as_double() const {
        switch (kind) {
            case Kind::integer:
                return static_cast<double>(integer);
            case Kind::large_unsigned:
                return static_cast<double>(large);
            case Kind::real:
                break;
        }
        return real;
    }
};

void set_number(const Register& reg, RawNumber raw, bool bit_table, DecodedValue& v) {
    const NumberStyle style = style_for(reg, bit_table);
    const double value = raw.as_double() * reg.scale;
    const bool integer = raw.kind == RawNumber::Kind::integer;
    if (style.kind == NumberStyle::Kind::integer && integer) {
        append_decimal(v.value, raw.integer);
    } else if (style.kind == NumberStyle::Kind::integer &&
               raw.kind == RawNumber::Kind::large_unsigned) {
        const fmt::format_int text(raw.large);
        v.value.append(text.data(), text.size());
    } else if (style.kind == NumberStyle::Kind::fixed && integer &&
               reg.scale == scale_for_decimals(style.decimals) &&
               raw.integer > -(std::int64_t{1} << 51) && raw.integer < (std::int64_t{1} << 51)) {
        // `decimals = N` (or a scale of exactly 10^-N) on an integer register, the usual case.
        append_shifted_decimal(v.value, raw.integer, style.decimals);
    } else {
        append_number(v.value, value, style);
    }
    v.unit = reg.unit;
    check_range(reg, value, style, v);
}

void set_enum(const Register& reg, std::uint32_t raw, DecodedValue& v) {
    const auto label = reg.labels.find(raw);
    if (label != reg.labels.end()) {
        v.value = label->second;
        return;
    }
    append_decimal(v.value, raw);
    add_note(v, note_id::value_out_of_range).append("no label for ").append(v.value);
}

void append_bit_names(std::string& out, const Register& reg, std::uint16_t word) {
    if (word == 0) {
        out += "none";
        return;
    }
    bool first = true;
    for (std::uint32_t bit = 0; bit < 16; ++bit) {
        if ((word & (1U << bit)) == 0) continue;
        if (!first) out += ", ";
        first = false;
        const auto name = reg.labels.find(bit);
        if (name != reg.labels.end()) {
            out += name->second;
        } else {
            fmt::format_to(std::back_inserter(out), "bit {}", bit);
        }
    }
}

void append_ascii_text(std::string& out, Words words) {
    for (const std::uint16_t w : words) {
        for (const unsigned byte : {unsigned{w} >> 8U, unsigned{w} & 0xFFU}) {
            if (byte == 0) return;
            if (byte >= 0x20 && byte < 0x7F) {
                out += static_cast<char>(byte);
            } else {
                fmt::format_to(std::back_inserter(out), "\\x{:02X}", byte);
            }
        }
    }
}

// The value of a register of several words, as the word order puts them together.
std::uint64_t combine(const Register& reg, Words words) {
    const bool reversed = reverses_registers(reg.word_order);
    const bool swapped = swaps_bytes(reg.word_order);
    std::uint64_t raw = 0;
    for (std::size_t i = 0; i < words.size(); ++i) {
        const std::uint16_t word = words[reversed ? words.size() - 1 - i : i];
        raw = (raw << 16U) | (swapped ? ((word & 0xFFU) << 8U) | (word >> 8U) : word);
    }
    return raw;
}

// A write carries a command rather than a quantity when its raw value is listed in
// `writes`; the meaning replaces the number then (and a range makes no sense for it).
bool set_special_write(const Register& reg, std::uint64_t raw, DecodedValue& v) {
    if (raw > std::numeric_limits<std::uint32_t>::max()) return false;
    const auto meaning = reg.writes.find(static_cast<std::uint32_t>(raw));
    if (meaning == reg.writes.end()) return false;
    v.value = meaning->second;
    v.unit.clear();
    return true;
}

// Access the profile does not allow: a master writing a read-only register, or reading
// (and a device answering for) one that the manual says can only be written.
void note_access_mismatch(const Register& reg, bool write, DecodedValue& v) {
    if (write && reg.access == Access::read) {
        add_note(v, note_id::value_read_only) += "written, but the profile says read-only";
    }
    if (!write && reg.access == Access::write) {
        add_note(v, note_id::value_write_only) += "read, but the profile says write-only";
    }
}

// The functions below fill `v`, an empty value already in its place at the end of the
// record's list, writing into its strings (built elsewhere and moved in, they would be a
// copy each, and an allocation).
void unlisted(std::uint16_t address, std::uint16_t word, bool bit_table, DecodedValue& v) {
    v.address = address;
    if (bit_table) {
        v.value += bit_text(word);
        v.raw += bit_text(word);
    } else {
        append_decimal(v.value, word);
        append_hex_words(v.raw, Words(&word, 1));
    }
    add_note(v, note_id::value_unlisted) += "not in the profile";
}

// One coil or discrete input: always a single item, whatever length the profile gives.
void decode_bit(const Register& reg, std::uint16_t address, std::uint16_t item, bool write,
                DecodedValue& v) {
    v.address = address;
    v.name = reg.name;
    v.raw += bit_text(item);
    note_access_mismatch(reg, write, v);
    const std::uint32_t bit = item != 0 ? 1 : 0;
    if (write && set_special_write(reg, bit, v)) return;
    if (reg.type == ValueType::enumeration) {
        set_enum(reg, bit, v);
        return;
    }
    set_number(reg, RawNumber::of_integer(bit), true, v);
}

// A register whose every word is in the block.
void decode_register(const Register& reg, std::uint16_t address, Words words, bool write,
                     DecodedValue& v) {
    v.address = address;
    v.name = reg.name;
    append_hex_words(v.raw, words);
    note_access_mismatch(reg, write, v);
    const bool wide = is_multi_register(reg.type);
    const std::size_t needed = registers_of(reg.type);
    if (wide && words.size() < needed) {
        // Only a broken profile gets here (a 32-bit type of length 1); say so, do not guess.
        fmt::format_to(std::back_inserter(add_note(v, note_id::value_partial)),
                       "a {}-bit value needs {} registers, the profile gives {}", needed * 16,
                       needed, words.size());
        return;
    }
    const std::uint64_t raw = wide ? combine(reg, words.first(needed)) : words[0];
    if (write && set_special_write(reg, raw, v)) return;
    switch (reg.type) {
        case ValueType::u16:
        case ValueType::u32:
        case ValueType::u64:
            set_number(reg, RawNumber::of_unsigned(raw), false, v);
            break;
        case ValueType::i16:
            set_number(reg, RawNumber::of_integer(static_cast<std::int16_t>(raw)), false, v);
            break;
        case ValueType::i32:
            set_number(reg, RawNumber::of_integer(static_cast<std::int32_t>(raw)), false, v);
            break;
        case ValueType::i64:
            set_number(reg, RawNumber::of_integer(static_cast<std::int64_t>(raw)), false, v);
            break;
        case ValueType::f32:
            set_number(reg,
                       RawNumber::of_real(std::bit_cast<float>(static_cast<std::uint32_t>(raw))),
                       false, v);
            break;
        case ValueType::f64:
            set_number(reg, RawNumber::of_real(std::bit_cast<double>(raw)), false, v);
            break;
        case ValueType::enumeration:
            set_enum(reg, static_cast<std::uint32_t>(raw), v);
            break;
        case ValueType::bits:
            append_bit_names(v.value, reg, words[0]);
            break;
        case ValueType::string:
            append_ascii_text(v.value, words);
            break;
    }
}

// The words of a register that the block cuts: it starts inside the register, or ends
// before the register does. Its value cannot be known, so only the raw words are shown.
void partial(const Register& reg, std::uint16_t address, Words present, DecodedValue& v) {
    v.address = address;
    v.name = reg.name;
    append_hex_words(v.raw, present);
    const std::size_t offset = address - reg.address;
    const std::size_t count = present.size();
    const std::uint32_t last = std::uint32_t{reg.address} + reg.length - 1;
    auto text = std::back_inserter(add_note(v, note_id::value_partial));
    if (reg.length == 2 && registers_of(reg.type) == 2 && count == 1) {
        const bool high = (offset == 0) != reverses_registers(reg.word_order);
        fmt::format_to(text, "only the {} word of a 32-bit value", high ? "high" : "low");
    } else if (offset == 0) {
        fmt::format_to(text, "only the first {} of {} registers", count, reg.length);
    } else if (offset + count == reg.length) {
        fmt::format_to(text, "only the last {} of {} registers", count, reg.length);
    } else {
        fmt::format_to(text, "only registers {}-{} of {}", offset + 1, offset + count, reg.length);
    }
    if (is_multi_register(reg.type) && reg.length > 2) {
        fmt::format_to(text, " of a {}-bit value", reg.length * 16);
    }
    fmt::format_to(text, " (0x{:04X}-0x{:04X})", reg.address, last);
}

// Devices often take a command word written into one half of a 32-bit register (the
// PDU clears its energy counter when 0xAABB is written to either half): that is the
// command, not half a value.
void partial_or_command(const Register& reg, std::uint16_t address, Words present, bool write,
                        DecodedValue& v) {
    if (write && present.size() == 1) {
        v.address = address;
        v.name = reg.name;
        append_hex_words(v.raw, present);
        if (set_special_write(reg, present[0], v)) {
            note_access_mismatch(reg, write, v);
            return;
        }
        v.clear();
    }
    partial(reg, address, present, v);
}

}  // namespace

const char* table_name(DataTable table) {
    switch (table) {
        case DataTable::coils:
            return "coil";
        case DataTable::discrete_inputs:
            return "discrete";
        case DataTable::holding_registers:
            return "holding";
        case DataTable::input_registers:
            return "input";
        case DataTable::none:
            break;
    }
    return "";  // not a table any profile can name: everything comes out unlisted
}

void DecodedValue::clear() {
    address = 0;
    name.clear();
    value.clear();
    unit.clear();
    raw.clear();
    notes.clear();
}

void decode_values(const Profile& profile, const DataBlock& block, ReusedList<DecodedValue>& out) {
    const std::string_view table = block.custom_table.empty()
                                       ? std::string_view(table_name(block.table))
                                       : std::string_view(block.custom_table);
    const bool bit_table = is_bit_table(table);
    // Addresses do not wrap around: what a block carries past 0xFFFF is not decoded.
    const std::size_t count =
        std::min<std::size_t>(block.values.size(), std::size_t{0x10000} - block.start);
    const Words words(block.values.data(), count);

    const std::span<const Register> table_registers = profile.registers_in(table);
    // A block's addresses go up: the register after the last one found is usually the
    // next one asked for, so it is looked at before the table is searched. (The table is
    // sorted by address without overlaps, so a register that starts at the address is
    // the one covering it.)
    const Register* next = table_registers.data();
    const Register* const end = table_registers.data() + table_registers.size();
    for (std::size_t i = 0; i < count;) {
        const auto address = static_cast<std::uint16_t>(block.start + i);
        const Register* reg = next != end && next->address == address
                                  ? next
                                  : Profile::covering(table_registers, address);
        if (reg != nullptr) next = reg + 1;
        if (bit_table) {
            if (reg != nullptr && reg->address != address) reg = nullptr;
            if (reg != nullptr) {
                decode_bit(*reg, address, words[i], block.write, out.add());
            } else {
                unlisted(address, words[i], true, out.add());
            }
            ++i;
            continue;
        }
        // The lookup trusts the profile's order; an unsorted profile must not lead us to a
        // register that does not actually cover this address.
        if (reg == nullptr || reg->address > address ||
            std::size_t{address} - reg->address >= reg->length) {
            unlisted(address, words[i], false, out.add());
            ++i;
            continue;
        }
        const std::size_t offset = address - reg->address;
        const std::size_t present = std::min<std::size_t>(reg->length - offset, count - i);
        const Words here = words.subspan(i, present);
        if (offset == 0 && present == reg->length) {
            decode_register(*reg, address, here, block.write, out.add());
        } else {
            partial_or_command(*reg, address, here, block.write, out.add());
        }
        i += present;
    }
}

}  // namespace rtuscope
