// --as: registers typed on the command line, parsed and put into the bus's profiles.
#include "profiles/quick_type.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <map>
#include <string>
#include <tuple>

namespace rtuscope {
namespace {

constexpr const char* kExpected =
    "expected SLAVE[:TABLE]:ADDR=TYPE[/ORDER][*SCALE][:UNIT], e.g. 247:input:0x4082=f32/cdab "
    "or 3:0x0010=u16*0.1:V";

std::optional<double> parse_scale(std::string_view text) {
    double value = 0;
    const auto* end = text.data() + text.size();
    const auto [ptr, ec] = std::from_chars(text.data(), end, value);
    if (text.empty() || ec != std::errc{} || ptr != end || !std::isfinite(value) || value == 0) {
        return std::nullopt;
    }
    return value;
}

bool is_standard_table(std::string_view table) {
    return table == "holding" || table == "input" || is_bit_table(table);
}

bool registers_overlap(const Register& a, const Register& b) {
    return a.table == b.table && a.address < b.address + b.length &&
           b.address < a.address + a.length;
}

// `profile` with `typed` in it: what the profile says at those addresses gives way, but
// the name of the register that started there stays, with its access and description.
void put_register(Profile& profile, Register typed) {
    if (const Register* named = profile.register_at(typed.table, typed.address)) {
        typed.name = named->name;
        typed.access = named->access;
        typed.description = named->description;
    }
    std::erase_if(profile.registers,
                  [&](const Register& r) { return registers_overlap(r, typed); });
    const auto place = std::upper_bound(
        profile.registers.begin(), profile.registers.end(), typed,
        [](const Register& a, const Register& b) {
            return std::tie(a.table, a.address) < std::tie(b.table, b.address);
        });
    profile.registers.insert(place, std::move(typed));
}

}  // namespace

Result<QuickType> parse_quick_type(std::string_view text) {
    auto bad = [&](const std::string& what) {
        return Error{fmt::format("bad --as \"{}\": {} ({})", text, what, kExpected)};
    };
    const auto eq = text.find('=');
    if (eq == std::string_view::npos) return bad("no =TYPE");
    const std::string_view where = text.substr(0, eq);
    std::string_view type_text = text.substr(eq + 1);

    QuickType q;
    Register& r = q.reg;
    const auto first_colon = where.find(':');
    const auto last_colon = where.rfind(':');
    if (first_colon == std::string_view::npos) return bad("no :ADDR after the slave");
    const auto slave = parse_number_up_to(where.substr(0, first_colon), 255);
    if (!slave) {
        return bad(fmt::format("slave \"{}\" is not an address 0-255",
                               where.substr(0, first_colon)));
    }
    q.slave = static_cast<std::uint8_t>(*slave);
    if (last_colon != first_colon) {
        r.table = std::string(where.substr(first_colon + 1, last_colon - first_colon - 1));
        if (!is_standard_table(r.table)) {
            return bad(fmt::format("unknown table \"{}\" (holding, input, coil, discrete)",
                                   r.table));
        }
    }
    const std::string_view address_text = where.substr(last_colon + 1);
    const auto address = parse_number_up_to(address_text, 0xFFFF);
    if (!address) {
        return bad(fmt::format("address \"{}\" is not a number 0-65535 (decimal or 0x hex)",
                               address_text));
    }
    r.address = static_cast<std::uint16_t>(*address);
    r.name = fmt::format("reg_0x{:04X}", r.address);
    r.access = Access::read_write;  // what is read and what is written both decode quietly

    if (const auto colon = type_text.find(':'); colon != std::string_view::npos) {
        r.unit = std::string(type_text.substr(colon + 1));
        if (r.unit.empty()) return bad("an empty :UNIT");
        type_text = type_text.substr(0, colon);
    }
    if (const auto star = type_text.find('*'); star != std::string_view::npos) {
        const auto scale = parse_scale(type_text.substr(star + 1));
        if (!scale) {
            return bad(fmt::format("scale \"{}\" is not a number other than 0",
                                   type_text.substr(star + 1)));
        }
        r.scale = *scale;
        type_text = type_text.substr(0, star);
    }
    std::string_view order_text;
    const auto slash = type_text.find('/');
    if (slash != std::string_view::npos) {
        order_text = type_text.substr(slash + 1);
        type_text = type_text.substr(0, slash);
    }
    const auto type = value_type_named(type_text);
    if (!type) return bad(fmt::format("unknown type \"{}\" ({})", type_text, value_type_names()));
    if (*type == ValueType::enumeration || *type == ValueType::string) {
        return bad(fmt::format("type {} needs a profile (its {})", type_text,
                               *type == ValueType::string ? "length" : "labels"));
    }
    if (is_bit_table(r.table) && *type != ValueType::u16) {
        return bad(fmt::format("a {} is a single bit: type u16", r.table));
    }
    r.type = *type;
    r.length = registers_of(r.type);
    if (slash != std::string_view::npos) {
        if (!is_multi_register(r.type)) {
            return bad(fmt::format("/{}: a word order is only for u32, i32, f32, u64, i64 and f64",
                                   order_text));
        }
        const auto order = word_order_named(order_text);
        if (!order) {
            return bad(fmt::format("unknown word order \"{}\" ({})", order_text,
                                   word_order_names()));
        }
        r.word_order = *order;
    }
    if (std::uint32_t{r.address} + r.length > 0x10000) {
        return bad(fmt::format("a {} at 0x{:04X} goes past address 0xFFFF", type_text, r.address));
    }
    return q;
}

void apply_quick_types(Bus& bus, const std::vector<QuickType>& types) {
    std::map<std::uint8_t, Profile> own;
    for (const QuickType& q : types) {
        auto [entry, added] = own.try_emplace(q.slave);
        Profile& profile = entry->second;
        if (added) {
            if (const Profile* base = bus.profile_for(q.slave)) {
                profile = *base;
            } else {
                profile.name = fmt::format("as-{}", q.slave);
                profile.title = "registers typed with --as";
            }
        }
        put_register(profile, q.reg);
    }
    for (auto& [slave, profile] : own) bus.assign_own(slave, std::move(profile));
}

}  // namespace rtuscope
