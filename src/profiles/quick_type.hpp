// --as SLAVE[:TABLE]:ADDR=TYPE: one register typed on the command line, as a line of a
// profile would type it, for a slave with a profile (the register is added, or replaces
// what the profile says at that address) or without one (the slave gets a profile of
// just such registers).
#pragma once

#include <cstdint>
#include <string_view>
#include <vector>

#include "profiles/bus.hpp"
#include "profiles/profile.hpp"
#include "util/result.hpp"

namespace rtuscope {

struct QuickType {
    std::uint8_t slave = 0;
    Register reg;  // named "reg_0x4082"; named after the profile's register when applied
};

// "247:input:0x4082=f32/cdab", "3:0x0010=u16*0.1:V": TYPE is a profile's type name with an
// optional /ORDER (types of several registers), *SCALE and :UNIT. An error says what in
// the text is wrong.
Result<QuickType> parse_quick_type(std::string_view text);

// Every slave named gets its own copy of its profile with these registers in it, or a
// profile named "as-SLAVE" of only these registers.
void apply_quick_types(Bus& bus, const std::vector<QuickType>& types);

}  // namespace rtuscope
