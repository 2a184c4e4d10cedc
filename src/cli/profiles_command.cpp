#include "profiles_command.hpp"

#include <fmt/format.h>

#include <memory>

#include "bus_options.hpp"
#include "decode/pdu_decoders.hpp"
#include "errors.hpp"
#include "infer_command.hpp"
#include "util/text.hpp"
#include "util/text_file.hpp"

namespace rtuscope::cli {
namespace {

std::string number_text(double value) {
    return fmt::format("{}", value);
}

std::string scale_text(const Register& r) {
    if (r.decimals >= 0) return fmt::format("/10^{}", r.decimals);
    if (r.scale != 1.0) return fmt::format("x{}", number_text(r.scale));
    return "";
}

// How many registers the value takes and, for values of several, their word order: what
// turns the words read into the raw value ("2 low_first").
std::string registers_text(const Register& r) {
    if (is_bit_table(r.table)) return "bit";
    if (!is_multi_register(r.type)) return std::to_string(r.length);
    return fmt::format("{} {}", r.length, word_order_name(r.word_order));
}

std::string range_text(const Register& r) {
    if (!r.min && !r.max) return "";
    return fmt::format("{}..{}", r.min ? number_text(*r.min) : "",
                       r.max ? number_text(*r.max) : "");
}

int list_profiles(const BusArgs& args) {
    auto bus = build_bus(args);
    if (!bus) {
        print_error(bus.error());
        return 1;
    }
    if (Status s = assign_devices(**bus, args); !s) {
        print_error(s.error());
        return 2;
    }
    fmt::print("{:<18} {:<10} {:>9}  {}\n", "name", "addresses", "registers", "device");
    for (const Profile* p : (*bus)->profiles()) {
        fmt::print("{:<18} {:<10} {:>9}  {}\n", p->name,
                   fmt::format("{}-{}", p->first_address, p->last_address), p->registers.size(),
                   p->title);
    }
    return 0;
}

int show_profile(const BusArgs& args, const std::string& name) {
    auto bus = build_bus(args);
    if (!bus) {
        print_error(bus.error());
        return 1;
    }
    if (Status s = assign_devices(**bus, args); !s) {
        print_error(s.error());
        return 2;
    }
    const Profile* p = (*bus)->find_profile(name);
    if (p == nullptr) {
        fmt::print(stderr, "rtuscope: error: unknown profile \"{}\" (rtuscope profiles list)\n",
                   name);
        return 2;
    }
    fmt::print("{}: {}\n", p->name, p->title);
    if (!p->source.empty()) fmt::print("source: {}\n", p->source);
    fmt::print("file: {}\n", p->file);
    fmt::print("line: {}\n", p->line ? fmt::format("{} {}", p->line->baud, p->line->format())
                                     : std::string("not given"));
    fmt::print("addresses: {}-{}{}\n", p->first_address, p->last_address,
               p->broadcast ? fmt::format(", broadcast {}", *p->broadcast) : std::string());
    fmt::print("exception answers: {}\n",
               p->exception_answers ? "yes" : "no (errors are answered with silence)");
    fmt::print("registers per request: at most {}\n", p->max_registers);
    for (const FunctionSpec& f : p->functions) {
        const char* answer = f.answer == Answer::echo   ? "echo"
                             : f.answer == Answer::none ? "none"
                                                        : "standard";
        const std::string_view layout = device_layout_name(f.decode_request);
        fmt::print(
            "function 0x{:02X} {}: request {} bytes, answer {}{}\n", f.code, f.name,
            f.request_length.kind == LengthRule::Kind::fixed ? std::to_string(f.request_length.n)
                                                             : "standard",
            answer, layout.empty() ? "" : fmt::format(", {} in table {}", layout, f.device_table));
    }
    // Every field that changes how a raw value becomes the printed one has its column, or
    // (labels, writes) its place in the last.
    fmt::print("\n{:<9} {:<7} {:<24} {:<6} {:<12} {:<7} {:<8} {:<6} {:<14} {}\n", "table",
               "address", "name", "type", "registers", "scale", "unit", "access", "range",
               "description");
    for (const Register& r : p->registers) {
        std::string extra = r.description;
        for (const auto& [raw, label] : r.labels) {
            extra += fmt::format("{}{}={}", extra.empty() ? "" : "; ", raw, label);
        }
        for (const auto& [raw, meaning] : r.writes) {
            extra += fmt::format("{}write 0x{:04X}: {}", extra.empty() ? "" : "; ", raw, meaning);
        }
        const auto ha_class = [&](std::string_view key, const std::optional<std::string>& value) {
            if (!value) return;
            extra += fmt::format("{}{}={}", extra.empty() ? "" : "; ", key,
                                 value->empty() ? "none" : *value);
        };
        ha_class("home_assistant.device_class", r.ha_device_class);
        ha_class("home_assistant.state_class", r.ha_state_class);
        fmt::print("{:<9} 0x{:04X}  {:<24} {:<6} {:<12} {:<7} {:<8} {:<6} {:<14} {}\n", r.table,
                   r.address, r.name, value_type_name(r.type), registers_text(r), scale_text(r), r.unit,
                   access_text(r.access), range_text(r), extra);
    }
    return 0;
}

// One file given to `profiles check`: what it is and, for a profile, what loading it
// gave (or why the file could not be read).
struct CheckedFile {
    std::string path;
    TomlFileKind kind = TomlFileKind::profile;
    std::string text;     // a bus file's, read again once every profile is known
    ProfileLoad profile;  // a profile's load, or the reason the file could not be read
};

// Like a compiler's diagnostics: on stderr, one per line, so that editors and CI logs can
// jump to FILE:LINE:COL.
void print_check_problems(const std::vector<ProfileProblem>& problems) {
    for (const ProfileProblem& problem : problems) fmt::print(stderr, "{}\n", problem.to_string());
}

int check_files(const BusArgs& args, const std::vector<std::string>& files) {
    auto bus = build_bus(args);  // --profile and --profile-dir, for the bus files' names
    if (!bus) {
        print_error(bus.error());
        return 1;
    }
    // Profiles first: a bus file may name one checked with it, wherever it stands on the
    // command line.
    std::vector<CheckedFile> checked;
    for (const std::string& path : files) {
        CheckedFile& file = checked.emplace_back();
        file.path = path;
        auto text = read_text_file(path);
        if (!text) {
            file.profile.problems.push_back({path, 0, 0, text.error().message});
            continue;
        }
        file.kind = toml_file_kind(*text);
        if (file.kind == TomlFileKind::profile) {
            file.profile = load_profile_text(*text, path);
            if (file.profile.profile) (*bus)->add_profile(*file.profile.profile);
        } else {
            file.text = std::move(*text);
        }
    }
    int status = 0;
    for (const CheckedFile& file : checked) {
        switch (file.kind) {
            case TomlFileKind::profile:
                if (!file.profile.profile) {
                    print_check_problems(file.profile.problems);
                    status = 1;
                    break;
                }
                fmt::print("{}: ok, profile \"{}\" with {} {}\n", file.path,
                           file.profile.profile->name, file.profile.profile->registers.size(),
                           plural(file.profile.profile->registers.size(), "register", "registers"));
                break;
            case TomlFileKind::bus: {
                const BusLoad load = read_bus_text(**bus, file.text, file.path);
                if (!load.bus) {
                    print_check_problems(load.problems);
                    status = 1;
                    break;
                }
                const std::size_t devices = load.bus->devices.size();
                fmt::print("{}: ok, bus file with {} device{}{}\n", file.path, devices,
                           devices == 1 ? "" : "s",
                           load.bus->line ? fmt::format(" (line {} {})", load.bus->line->baud,
                                                        load.bus->line->format())
                                          : std::string());
                break;
            }
            case TomlFileKind::neither:
                fmt::print(stderr,
                           "{}: neither a device profile ([device]) nor a bus file ([[device]] "
                           "entries or line): nothing to check\n",
                           file.path);
                status = 1;
                break;
        }
    }
    return status;
}

}  // namespace

void add_profiles_command(CLI::App& app, int& exit_code) {
    CLI::App* cmd = app.add_subcommand("profiles", "List, show, check and infer device profiles");
    cmd->require_subcommand(1);

    auto list_args = std::make_shared<BusArgs>();
    CLI::App* list = cmd->add_subcommand("list", "The profiles rtuscope knows");
    add_bus_options(*list, *list_args);
    list->callback([list_args, &exit_code] { exit_code = list_profiles(*list_args); });

    auto show_args = std::make_shared<BusArgs>();
    auto name = std::make_shared<std::string>();
    CLI::App* show = cmd->add_subcommand("show", "One profile's register table");
    show->add_option("NAME", *name, "Profile name (rtuscope profiles list)")->required();
    add_bus_options(*show, *show_args);
    show->callback([show_args, name, &exit_code] { exit_code = show_profile(*show_args, *name); });

    auto check_args = std::make_shared<BusArgs>();
    auto files = std::make_shared<std::vector<std::string>>();
    CLI::App* check = cmd->add_subcommand(
        "check", "Validate profile and bus files: every mistake as FILE:LINE:COL: message");
    check->add_option("FILE", *files, "Profile or bus files (told apart by their content)")
        ->required();
    add_profile_options(*check, *check_args);
    check->callback(
        [check_args, files, &exit_code] { exit_code = check_files(*check_args, *files); });

    add_infer_command(*cmd, exit_code);
}

}  // namespace rtuscope::cli
