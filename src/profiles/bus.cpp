#include "profiles/bus.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <tuple>

#include "profiles/toml.hpp"
#include "profiles/toml_errors.hpp"
#include "util/text_file.hpp"

namespace rtuscope {
namespace {

std::string unknown_profile(const Bus& bus, std::string_view name) {
    std::string known;
    for (const Profile* p : bus.profiles()) known += (known.empty() ? "" : ", ") + p->name;
    return fmt::format("unknown profile \"{}\" (known: {})", name, known);
}

}  // namespace

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
    if (profile == nullptr) return Error{unknown_profile(*this, profile_name)};
    by_address_[address] = profile;
    update_owners();
    return ok_status();
}

void Bus::assign_own(std::uint8_t address, Profile profile) {
    by_address_[address] = &own_profiles_.emplace_back(std::move(profile));
    update_owners();
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

Status assign_device_option(Bus& bus, std::string_view option) {
    const auto eq = option.find('=');
    const auto address = parse_number_up_to(option.substr(0, eq), 255);
    if (eq == std::string_view::npos || !address) {
        return Error{fmt::format(
            "bad --device \"{}\" (expected ADDRESS=PROFILE, e.g. 3=pdu485, address 0-255)",
            option)};
    }
    return bus.assign(static_cast<std::uint8_t>(*address), option.substr(eq + 1));
}

namespace {

TomlFileKind kind_of(const toml::table& root) {
    const toml::node* device = root.get("device");
    if (device != nullptr && device->is_table()) return TomlFileKind::profile;
    if (device != nullptr && device->is_array()) return TomlFileKind::bus;
    if (root.contains("register") || root.contains("function")) return TomlFileKind::profile;
    if (root.contains("line")) return TomlFileKind::bus;
    return TomlFileKind::neither;
}

// Reads a bus file's table, collecting every mistake rather than stopping at the first.
class BusReader {
  public:
    BusReader(const Bus& known, std::string file) : known_(known), file_(std::move(file)) {}

    BusLoad read(const std::string& text) {
        toml::table root;
        try {
            root = toml::parse(text, file_);
        } catch (const toml::parse_error& err) {
            TomlSyntaxError e =
                explain_toml_error(err.description(), static_cast<int>(err.source().begin.line),
                                   static_cast<int>(err.source().begin.column), text);
            problems_.push_back({file_, e.line, e.column, std::move(e.message)});
            return finish();
        }
        if (kind_of(root) == TomlFileKind::profile) {
            // Its keys would each be a mistake here; one line says what is.
            problems_.push_back({file_, 0, 0,
                                 "is a device profile ([device]), not a bus file: give it with "
                                 "--profile"});
            return finish();
        }
        for (const auto& [key, node] : root) {
            if (key != "line" && key != "device") {
                unknown_key(key, node,
                            fmt::format("unknown key \"{}\" (a bus file has line and [[device]])",
                                        key.str()));
            }
        }
        if (const toml::node* line = root.get("line")) read_line(*line);
        if (const toml::node* devices = root.get("device")) {
            if (const toml::array* list = devices->as_array()) {
                for (const toml::node& entry : *list) read_device(entry);
            } else {
                problem(*devices, "device must be an array of tables: [[device]]");
            }
        }
        return finish();
    }

  private:
    const Bus& known_;
    std::string file_;
    BusFile bus_;
    std::vector<ProfileProblem> problems_;

    void problem(const toml::source_region& where, std::string message) {
        problems_.push_back({file_, static_cast<int>(where.begin.line),
                             static_cast<int>(where.begin.column), std::move(message)});
    }
    void problem(const toml::node& node, std::string message) {
        problem(node.source(), std::move(message));
    }
    // An unknown key is reported where the key stands.
    void unknown_key(const toml::key& key, const toml::node& node, std::string message) {
        problem(key.source().begin.line != 0 ? key.source() : node.source(), std::move(message));
    }

    BusLoad finish() {
        std::stable_sort(problems_.begin(), problems_.end(),
                         [](const ProfileProblem& a, const ProfileProblem& b) {
                             return std::tie(a.line, a.column) < std::tie(b.line, b.column);
                         });
        BusLoad load;
        if (problems_.empty()) load.bus = std::move(bus_);
        load.problems = std::move(problems_);
        return load;
    }

    void read_line(const toml::node& line) {
        const auto text = line.value<std::string>();
        if (!text) {
            problem(line, "line must be a string like \"9600 8N1\"");
            return;
        }
        auto settings = parse_line_settings(*text);
        if (settings) {
            bus_.line = *settings;
        } else {
            problem(line, settings.error().message);
        }
    }

    void read_device(const toml::node& entry) {
        const toml::table* device = entry.as_table();
        if (device == nullptr) {
            problem(entry, "each [[device]] must be a table");
            return;
        }
        for (const auto& [key, node] : *device) {
            if (key != "address" && key != "profile") {
                unknown_key(key, node, fmt::format("unknown key \"{}\" in [[device]]", key.str()));
            }
        }
        const toml::node* address = device->get("address");
        const toml::node* profile = device->get("profile");
        if (address == nullptr || profile == nullptr) {
            problem(entry, "[[device]] needs address and profile");
        }
        std::optional<std::int64_t> number;
        if (address != nullptr) {
            number = address->value<std::int64_t>();
            if (!number || *number < 0 || *number > 255) {
                problem(*address, "address must be a number from 0 to 255");
                number.reset();
            }
        }
        std::optional<std::string> name;
        if (profile != nullptr) {
            name = profile->value<std::string>();
            if (!name) {
                problem(*profile, "profile must be a string");
            } else if (known_.find_profile(*name) == nullptr) {
                problem(*profile, unknown_profile(known_, *name));
                name.reset();
            }
        }
        if (number && name) {
            bus_.devices.push_back({static_cast<std::uint8_t>(*number), std::move(*name)});
        }
    }
};

}  // namespace

BusLoad read_bus_text(const Bus& known, const std::string& text, const std::string& file_name) {
    return BusReader(known, file_name).read(text);
}

std::vector<ProfileProblem> load_bus_file(Bus& bus, const std::string& path) {
    auto text = read_text_file(path);
    if (!text) return {{path, 0, 0, text.error().message}};
    BusLoad load = read_bus_text(bus, *text, path);
    if (!load.bus) return std::move(load.problems);
    if (load.bus->line) bus.set_line(*load.bus->line);
    for (const BusDevice& device : load.bus->devices) {
        // Every name was checked against this bus: assigning cannot fail.
        (void)bus.assign(device.address, device.profile);
    }
    return {};
}

TomlFileKind toml_file_kind(const std::string& text) {
    try {
        return kind_of(toml::parse(text));
    } catch (const toml::parse_error&) {
        return TomlFileKind::profile;
    }
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
