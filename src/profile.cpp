// Lookups in a loaded profile.
#include "rtuscope/profile.hpp"

#include <algorithm>

namespace rtuscope {

const FunctionOverride* Profile::function(std::uint8_t code) const {
    for (const FunctionOverride& f : functions) {
        if (f.code == code) return &f;
    }
    return nullptr;
}

const Register* Profile::register_covering(const std::string& table, std::uint16_t address) const {
    // Registers are sorted by (table, address) and do not overlap, so the candidate is
    // the last one that starts at or before `address`.
    auto after = std::upper_bound(
        registers.begin(), registers.end(), std::pair(&table, address),
        [](const std::pair<const std::string*, std::uint16_t>& key, const Register& r) {
            if (*key.first != r.table) return *key.first < r.table;
            return key.second < r.address;
        });
    if (after == registers.begin()) return nullptr;
    const Register& candidate = *std::prev(after);
    if (candidate.table != table) return nullptr;
    if (address - candidate.address >= candidate.length) return nullptr;
    return &candidate;
}

const Register* Profile::register_at(const std::string& table, std::uint16_t address) const {
    const Register* r = register_covering(table, address);
    return r != nullptr && r->address == address ? r : nullptr;
}

std::string ProfileProblem::to_string() const {
    return Error{message, file, line, column}.to_string();
}

}  // namespace rtuscope
