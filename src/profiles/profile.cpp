// Lookups in a loaded profile.
#include "profiles/profile.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "decode/pdu_decoders.hpp"

namespace rtuscope {

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

bool is_bit_table(std::string_view table) {
    return table == "coil" || table == "discrete";
}

FunctionSpec own_function(std::uint8_t code) {
    FunctionSpec f = standard_function(code);
    f.request_length = LengthRule::standard();
    f.table = DataTable::none;
    f.access = DataAccess::none;
    f.max_quantity = 0;
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
