// Lookups in a loaded profile.
#include "profiles/profile.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>

#include "decode/pdu_decoders.hpp"

namespace rtuscope {

const char* access_text(Access access) {
    switch (access) {
        case Access::read:
            return "R";
        case Access::write:
            return "W";
        case Access::read_write:
            return "RW";
    }
    return "";
}

double scale_for_decimals(int decimals) {
    // Decoding compares a register's scale with this for every value it prints.
    static const std::array<double, 10> kScales = [] {
        std::array<double, 10> scales{};
        for (std::size_t d = 0; d < scales.size(); ++d) {
            scales[d] = std::pow(10.0, -static_cast<double>(d));
        }
        return scales;
    }();
    return decimals >= 0 && static_cast<std::size_t>(decimals) < kScales.size()
               ? kScales[static_cast<std::size_t>(decimals)]
               : 0.0;
}

namespace {

struct TypeEntry {
    const char* name;
    ValueType type;
    std::uint16_t registers;
};

constexpr std::array<TypeEntry, 11> kTypes = {{
    {"u16", ValueType::u16, 1},
    {"i16", ValueType::i16, 1},
    {"u32", ValueType::u32, 2},
    {"i32", ValueType::i32, 2},
    {"f32", ValueType::f32, 2},
    {"u64", ValueType::u64, 4},
    {"i64", ValueType::i64, 4},
    {"f64", ValueType::f64, 4},
    {"bits", ValueType::bits, 1},
    {"enum", ValueType::enumeration, 1},
    {"string", ValueType::string, 0},
}};

struct OrderEntry {
    const char* name;
    WordOrder order;
    bool reverses_registers;
    bool swaps_bytes;
};

// The first entry of an order gives its name; high_first and low_first are what profiles
// have always called the two orders that keep the bytes of each register.
constexpr std::array<OrderEntry, 6> kOrders = {{
    {"high_first", WordOrder::abcd, false, false},
    {"low_first", WordOrder::cdab, true, false},
    {"badc", WordOrder::badc, false, true},
    {"dcba", WordOrder::dcba, true, true},
    {"abcd", WordOrder::abcd, false, false},
    {"cdab", WordOrder::cdab, true, false},
}};

const TypeEntry& type_entry(ValueType type) {
    for (const TypeEntry& e : kTypes) {
        if (e.type == type) return e;
    }
    return kTypes.back();  // not reached: every type has its entry
}

const OrderEntry& order_entry(WordOrder order) {
    for (const OrderEntry& e : kOrders) {
        if (e.order == order) return e;
    }
    return kOrders.front();  // not reached: every order has its entry
}

}  // namespace

std::optional<ValueType> value_type_named(std::string_view name) {
    for (const TypeEntry& e : kTypes) {
        if (std::string_view(e.name) == name) return e.type;
    }
    return std::nullopt;
}

bool is_numeric(ValueType type) {
    switch (type) {
        case ValueType::u16:
        case ValueType::i16:
        case ValueType::u32:
        case ValueType::i32:
        case ValueType::f32:
        case ValueType::u64:
        case ValueType::i64:
        case ValueType::f64:
            return true;
        case ValueType::bits:
        case ValueType::enumeration:
        case ValueType::string:
            break;
    }
    return false;
}

const char* value_type_name(ValueType type) {
    return type_entry(type).name;
}

const char* value_type_names() {
    return "u16, i16, u32, i32, f32, u64, i64, f64, bits, enum, string";
}

std::uint16_t registers_of(ValueType type) {
    return type_entry(type).registers;
}

bool is_multi_register(ValueType type) {
    return type_entry(type).registers > 1;
}

std::optional<WordOrder> word_order_named(std::string_view name) {
    for (const OrderEntry& e : kOrders) {
        if (std::string_view(e.name) == name) return e.order;
    }
    return std::nullopt;
}

const char* word_order_name(WordOrder order) {
    return order_entry(order).name;
}

const char* word_order_names() {
    return "abcd, cdab, badc, dcba, high_first (abcd), low_first (cdab)";
}

bool reverses_registers(WordOrder order) {
    return order_entry(order).reverses_registers;
}

bool swaps_bytes(WordOrder order) {
    return order_entry(order).swaps_bytes;
}

std::optional<unsigned> parse_number_up_to(std::string_view text, unsigned max) {
    unsigned value = 0;
    int base = 10;
    if (text.starts_with("0x") || text.starts_with("0X")) {
        text.remove_prefix(2);
        base = 16;
    }
    const auto* end = text.data() + text.size();
    const auto [ptr, ec] = std::from_chars(text.data(), end, value, base);
    if (text.empty() || ec != std::errc{} || ptr != end || value > max) return std::nullopt;
    return value;
}

bool is_bit_table(std::string_view table) {
    return table == "coil" || table == "discrete";
}

FunctionSpec own_function(std::uint8_t code) {
    FunctionSpec f = standard_function(code);
    f.request_length = LengthRule::standard();
    f.table = DataTable::none;
    f.access = DataAccess::none;
    f.max_quantity = 0;
    f.request_word = RequestWord::none;
    f.answer_repeats_word = false;
    f.decode_request = f.decode_response = decode_data_bytes;
    f.device_table = "holding";
    return f;
}

const FunctionSpec* Profile::function(std::uint8_t code) const {
    for (const FunctionSpec& f : functions) {
        if (f.code == code) return &f;
    }
    return nullptr;
}

std::span<const Register> Profile::registers_in(std::string_view table) const {
    struct ByTable {
        bool operator()(const Register& r, std::string_view t) const { return r.table < t; }
        bool operator()(std::string_view t, const Register& r) const { return t < r.table; }
    };
    const auto [first, last] =
        std::equal_range(registers.begin(), registers.end(), table, ByTable{});
    return {first, last};
}

const Register* Profile::covering(std::span<const Register> table, std::uint16_t address) {
    // Registers are sorted by address and do not overlap, so the candidate is the last
    // one that starts at or before `address`.
    const auto after =
        std::upper_bound(table.begin(), table.end(), address,
                         [](std::uint16_t a, const Register& r) { return a < r.address; });
    if (after == table.begin()) return nullptr;
    const Register& candidate = *std::prev(after);
    if (address - candidate.address >= candidate.length) return nullptr;
    return &candidate;
}

const Register* Profile::register_covering(const std::string& table, std::uint16_t address) const {
    return covering(registers_in(table), address);
}

const Register* Profile::register_at(const std::string& table, std::uint16_t address) const {
    const Register* r = register_covering(table, address);
    return r != nullptr && r->address == address ? r : nullptr;
}

std::string ProfileProblem::to_string() const {
    return Error{message, file, line, column}.to_string();
}

}  // namespace rtuscope
