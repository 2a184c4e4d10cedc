#include "infer/profile_writer.hpp"

#include <fmt/format.h>

#include <set>

namespace rtuscope::infer {
namespace {

// reg_0x4082 for a holding or input register, unless both tables have that address (then
// holding_0x4082 and input_0x4082: names are unique in a profile); coil_ and discrete_
// for bits.
std::string placeholder(const RegisterGuess& g, const std::set<std::uint16_t>& in_both) {
    const bool bits = is_bit_table(g.table);
    const char* prefix = bits || in_both.contains(g.address) ? table_name(g.table) : "reg";
    return fmt::format("{}_0x{:04X}", prefix, g.address);
}

std::string labels_toml(const RegisterGuess& g) {
    std::string out;
    for (std::uint16_t v : g.labels) {
        out += fmt::format("{}\"{}\" = \"{}_{}\"", out.empty() ? "" : ", ", v,
                           g.type == ValueType::bits ? "bit" : "value", v);
    }
    return "{ " + out + " }";
}

}  // namespace

std::string draft_profile_name(std::uint8_t slave) {
    return fmt::format("slave-{}", slave);
}

std::string write_profile(const DeviceGuess& device, const std::string& source) {
    std::string out;
    out += fmt::format("# Draft profile of slave {}, inferred by `rtuscope profiles infer` from {}\n",
                       device.slave, source);
    out += fmt::format("# ({} answered reads). Only the registers seen on the bus are listed.\n",
                       device.answered_reads);
    out += "# Each register's comment gives the evidence for its type and a confidence; rename\n"
           "# the reg_0x... placeholders, add units, scales and descriptions, then check it:\n"
           "# rtuscope profiles check FILE\n#\n# Poll map:\n";
    for (const std::string& line : device.poll_map) out += "#   " + line + "\n";
    out += fmt::format("\n[device]\nname = \"{}\"\n", draft_profile_name(device.slave));
    out += fmt::format("title = \"Slave {}, inferred from traffic\"\n", device.slave);
    out += fmt::format("source = \"rtuscope profiles infer {}\"\n", source);
    out += fmt::format("addresses = [{}, {}]\n", device.slave, device.slave);

    std::set<std::uint16_t> holding;
    std::set<std::uint16_t> in_both;
    for (const RegisterGuess& g : device.registers) {
        if (g.table == Table::holding) holding.insert(g.address);
    }
    for (const RegisterGuess& g : device.registers) {
        if (g.table == Table::input && holding.contains(g.address)) in_both.insert(g.address);
    }
    for (const RegisterGuess& g : device.registers) {
        out += "\n";
        std::string headline = fmt::format("{}, confidence {}", reading_name(g.type, g.word_order),
                                           confidence_name(g.confidence));
        if (g.constant) headline += ", constant";
        if (g.counter) headline += ", counter (total_increasing)";
        out += "# " + headline + "\n";
        for (const std::string& line : g.evidence) out += "#   " + line + "\n";
        out += "[[register]]\n";
        out += fmt::format("table = \"{}\"\n", table_name(g.table));
        out += fmt::format("address = 0x{:04X}\n", g.address);
        out += fmt::format("name = \"{}\"\n", placeholder(g, in_both));
        out += fmt::format("type = \"{}\"\n", value_type_name(g.type));
        if (is_multi_register(g.type)) {
            out += fmt::format("word_order = \"{}\"\n",
                               g.word_order == WordOrder::abcd ? "abcd" : "cdab");
        }
        if (g.type == ValueType::enumeration) out += "values = " + labels_toml(g) + "\n";
        if (g.type == ValueType::bits) out += "bits = " + labels_toml(g) + "\n";
        out += fmt::format("access = \"{}\"\n", access_text(g.access));
        if (g.counter) out += "home_assistant = { state_class = \"total_increasing\" }\n";
    }
    return out;
}

}  // namespace rtuscope::infer
