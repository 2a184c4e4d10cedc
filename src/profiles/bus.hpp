// The bus map: which slave address is which device profile, and the protocol rules that
// follow from it (a device's own function codes, echoes, broadcast address).
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "framing/functions.hpp"
#include "framing/line_settings.hpp"
#include "profiles/profile.hpp"
#include "util/result.hpp"

namespace rtuscope {

class Bus {
  public:
    Bus() = default;  // knows the bundled profiles (parsed when first asked for)
    // The address map points into the profile list: moving keeps those pointers valid
    // (a deque's elements stay where they are), copying would not.
    Bus(const Bus&) = delete;
    Bus& operator=(const Bus&) = delete;
    Bus(Bus&&) noexcept = default;
    Bus& operator=(Bus&&) noexcept = default;

    // A user's profile; one with the name of a bundled profile replaces it.
    void add_profile(Profile profile);
    [[nodiscard]] const Profile* find_profile(std::string_view name) const;
    [[nodiscard]] std::vector<const Profile*> profiles() const;

    Status assign(std::uint8_t address, std::string_view profile_name);
    // A profile for the slave at `address` alone (--as): find_profile does not know it.
    void assign_own(std::uint8_t address, Profile profile);
    [[nodiscard]] const Profile* profile_for(std::uint8_t address) const;
    // The profile that speaks for frames to or from `slave`: its own, or that of the
    // device that owns `slave` as its non-standard broadcast address (ZB-UVI485: 255).
    [[nodiscard]] const Profile* owner(std::uint8_t slave) const;
    [[nodiscard]] bool empty() const;
    // "zb-uvi485 on 1, 2, 3; pdu485 on 250", profiles in order of their first address.
    [[nodiscard]] std::string map_text() const;

    // Line settings from a bus file, else the one all assigned profiles agree on.
    [[nodiscard]] std::optional<LineSettings> line() const;
    void set_line(LineSettings line) { line_ = line; }

  private:
    // Every known profile, the bundled ones first. Parsing those is a third of start-up,
    // and most decodes name no device: they are parsed here, on first use.
    std::deque<Profile>& known() const;

    mutable std::deque<Profile> profiles_;  // stable addresses for the pointers below
    mutable bool bundled_added_ = false;
    std::deque<Profile> own_profiles_;  // assign_own's, stable like profiles_
    std::array<const Profile*, 256> by_address_{};
    // owner() of every address, worked out whenever the map or a profile changes: it is
    // asked several times per frame, and searching the map each time would make decoding
    // with profiles several times slower than without.
    std::array<const Profile*, 256> owners_{};
    void update_owners();
    std::optional<LineSettings> line_;
};

// "3=pdu485" (address 0-255, decimal or 0x hex).
Status assign_device_option(Bus& bus, std::string_view option);

// A bus file (TOML, docs/profiles.md): optional `line`, and [[device]] address + profile.
struct BusDevice {
    std::uint8_t address = 0;
    std::string profile;
};
struct BusFile {
    std::optional<LineSettings> line;
    std::vector<BusDevice> devices;  // in file order
};
// Reads and checks one bus file, every mistake with its position (like a profile's,
// sorted by position): unknown keys, bad line settings, addresses and profile names the
// bus does not know. The file only when there is no mistake.
struct BusLoad {
    std::optional<BusFile> bus;
    std::vector<ProfileProblem> problems;
};
BusLoad read_bus_text(const Bus& known, const std::string& text, const std::string& file_name);
// Reads a bus file into `bus` (its line settings and devices) and returns nothing; or,
// when the file has mistakes, returns them all and leaves `bus` as it was.
std::vector<ProfileProblem> load_bus_file(Bus& bus, const std::string& path);

// What a TOML file is, by its content: a device profile has a [device] table (or
// [[register]]s, [[function]]s), a bus file [[device]] entries or a top-level `line`.
// A text that is not valid TOML counts as a profile, whose loader says what is wrong.
enum class TomlFileKind : std::uint8_t { profile, bus, neither };
TomlFileKind toml_file_kind(const std::string& text);

// The standard rules, overridden per slave address by that slave's profile.
class BusRules final : public ProtocolRules {
  public:
    explicit BusRules(const Bus& bus) : bus_(bus) {}

    [[nodiscard]] const FunctionSpec& function(std::uint8_t slave,
                                               std::uint8_t code) const override;
    [[nodiscard]] bool is_broadcast(std::uint8_t slave) const override;
    [[nodiscard]] bool answers_errors(std::uint8_t slave) const override;

  private:
    const Bus& bus_;
};

}  // namespace rtuscope
