#include "profiles/bus.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>

#include "profiles/toml.hpp"
#include "profiles/toml_errors.hpp"
#include "util/text_file.hpp"

namespace rtuscope {

std::deque<Profile>& Bus::known() const {
    if (!bundled_added_) {
        profiles_.assign(bundled_profiles().begin(), bundled_profiles().end());
        bundled_added_ = true;
    }
    return profiles_;
}

void Bus::add_profile(Profile profile) {
    for (Profile& existing : known()) {
        if (existing.name == profile.name) {
            // Slaves already assigned keep pointing at this slot, now the user's profile.
            existing = std::move(profile);
            update_owners();  // its broadcast address may differ
            return;
        }
    }
    known().push_back(std::move(profile));
}

const Profile* Bus::find_profile(std::string_view name) const {
    for (const Profile& p : known()) {
        if (p.name == name) return &p;
    }
    return nullptr;
}

std::vector<const Profile*> Bus::profiles() const {
    std::vector<const Profile*> all;
    for (const Profile& p : known()) all.push_back(&p);
    std::sort(all.begin(), all.end(),
              [](const Profile* a, const Profile* b) { return a->name < b->name; });
    return all;
}

Status Bus::assign(std::uint8_t address, std::string_view profile_name) {
    const Profile* profile = find_profile(profile_name);
    if (profile == nullptr) {
        std::string known;
        for (const Profile* p : profiles()) known += (known.empty() ? "" : ", ") + p->name;
        return Error{fmt::format("unknown profile \"{}\" (known: {})", profile_name, known)};
    }
    by_address_[address] = profile;
    update_owners();
    return ok_status();
}

const Profile* Bus::profile_for(std::uint8_t address) const {
    return by_address_[address];
}

const Profile* Bus::owner(std::uint8_t slave) const {
    return owners_[slave];
}

void Bus::update_owners() {
    owners_ = by_address_;
    // An address of no device is owned by the first device (by address) that broadcasts
    // on it; 0, the standard broadcast address, never so.
    for (const Profile* p : by_address_) {
        if (p == nullptr || !p->broadcast || *p->broadcast == 0) continue;
        const Profile*& owner = owners_[*p->broadcast];
        if (owner == nullptr) owner = p;
    }
}

bool Bus::empty() const {
    return std::all_of(by_address_.begin(), by_address_.end(),
                       [](const Profile* p) { return p == nullptr; });
}

std::string Bus::map_text() const {
    std::vector<std::pair<const Profile*, std::string>> groups;
    for (unsigned address = 0; address < by_address_.size(); ++address) {
        const Profile* p = by_address_[address];
        if (p == nullptr) continue;
        auto group =
            std::find_if(groups.begin(), groups.end(), [p](const auto& g) { return g.first == p; });
        if (group == groups.end()) {
            groups.emplace_back(p, std::to_string(address));
        } else {
            group->second += ", " + std::to_string(address);
        }
    }
    std::string text;
    for (const auto& [profile, addresses] : groups) {
        text += fmt::format("{}{} on {}", text.empty() ? "" : "; ", profile->name, addresses);
    }
    return text;
}

std::optional<LineSettings> Bus::line() const {
    if (line_) return line_;
    std::optional<LineSettings> agreed;
    for (const Profile* p : by_address_) {
        if (p == nullptr || !p->line) continue;
        if (agreed && (agreed->baud != p->line->baud || agreed->format() != p->line->format())) {
            return std::nullopt;  // devices disagree: the user must say
        }
        agreed = p->line;
    }
    return agreed;
}

namespace {

std::optional<unsigned> parse_address(std::string_view text) {
    unsigned value = 0;
    int base = 10;
    if (text.starts_with("0x") || text.starts_with("0X")) {
        text.remove_prefix(2);
        base = 16;
    }
    const auto* end = text.data() + text.size();
    const auto [ptr, ec] = std::from_chars(text.data(), end, value, base);
    if (text.empty() || ec != std::errc{} || ptr != end || value > 255) return std::nullopt;
    return value;
}

}  // namespace

Status assign_device_option(Bus& bus, std::string_view option) {
    const auto eq = option.find('=');
    const auto address = parse_address(option.substr(0, eq));
    if (eq == std::string_view::npos || !address) {
        return Error{fmt::format(
            "bad --device \"{}\" (expected ADDRESS=PROFILE, e.g. 3=pdu485, address 0-255)",
            option)};
    }
    return bus.assign(static_cast<std::uint8_t>(*address), option.substr(eq + 1));
}

Status load_bus_file(Bus& bus, const std::string& path) {
    auto text = read_text_file(path);
    if (!text) return text.error();
    toml::table root;
    try {
        root = toml::parse(*text, path);
    } catch (const toml::parse_error& err) {
        TomlSyntaxError e =
            explain_toml_error(err.description(), static_cast<int>(err.source().begin.line),
                               static_cast<int>(err.source().begin.column), *text);
        return Error{std::move(e.message), path, e.line, e.column};
    }
    auto at = [&](const toml::node& node, std::string message) {
        return Error{std::move(message), path, static_cast<int>(node.source().begin.line),
                     static_cast<int>(node.source().begin.column)};
    };
    for (const auto& [key, node] : root) {
        if (key != "line" && key != "device") {
            return at(node, fmt::format("unknown key \"{}\" (a bus file has line and [[device]])",
                                        key.str()));
        }
    }
    if (const toml::node* line = root.get("line")) {
        const auto line_text = line->value<std::string>();
        if (!line_text) return at(*line, "line must be a string like \"9600 8N1\"");
        auto settings = parse_line_settings(*line_text);
        if (!settings) return at(*line, settings.error().message);
        bus.set_line(*settings);
    }
    const toml::node* devices = root.get("device");
    if (devices == nullptr) return ok_status();
    const toml::array* list = devices->as_array();
    if (list == nullptr) return at(*devices, "device must be an array of tables: [[device]]");
    for (const toml::node& entry : *list) {
        const toml::table* device = entry.as_table();
        if (device == nullptr) return at(entry, "each [[device]] must be a table");
        for (const auto& [key, node] : *device) {
            if (key != "address" && key != "profile") {
                return at(node, fmt::format("unknown key \"{}\" in [[device]]", key.str()));
            }
        }
        const toml::node* address = device->get("address");
        const toml::node* profile = device->get("profile");
        if (address == nullptr || profile == nullptr) {
            return at(entry, "[[device]] needs address and profile");
        }
        const auto number = address->value<std::int64_t>();
        if (!number || *number < 0 || *number > 255) {
            return at(*address, "address must be a number from 0 to 255");
        }
        const auto name = profile->value<std::string>();
        if (!name) return at(*profile, "profile must be a string");
        if (Status s = bus.assign(static_cast<std::uint8_t>(*number), *name); !s) {
            return at(*profile, s.error().message);
        }
    }
    return ok_status();
}

const FunctionSpec& BusRules::function(std::uint8_t slave, std::uint8_t code) const {
    const Profile* profile = bus_.owner(slave);
    const FunctionSpec* own = profile != nullptr ? profile->function(code & 0x7FU) : nullptr;
    return own != nullptr ? *own : standard_function(code);
}

bool BusRules::is_broadcast(std::uint8_t slave) const {
    const Profile* profile = bus_.owner(slave);
    // A device with its own broadcast address (ZB-UVI485: 255) may use 0 as an ordinary
    // address; when the bus map puts such a device on 0, 0 is that device.
    if (slave == 0) return profile == nullptr || !profile->broadcast.has_value();
    return profile != nullptr && profile->broadcast == slave;
}

bool BusRules::answers_errors(std::uint8_t slave) const {
    const Profile* profile = bus_.owner(slave);
    return profile == nullptr || profile->exception_answers;
}

}  // namespace rtuscope
