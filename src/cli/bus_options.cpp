#include "bus_options.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <filesystem>

namespace rtuscope::cli {

void add_profile_options(CLI::App& cmd, BusArgs& args) {
    cmd.add_option("--profile", args.profile_files,
                   "A device profile file (TOML, docs/profiles.md); repeatable")
        ->type_name("FILE");
    cmd.add_option("--profile-dir", args.profile_dir, "Load every *.toml profile in DIR")
        ->type_name("DIR");
}

void add_bus_options(CLI::App& cmd, BusArgs& args) {
    add_profile_options(cmd, args);
    cmd.add_option("--device", args.devices,
                   "Which slave is which device: ADDRESS=PROFILE, e.g. 3=pdu485; repeatable")
        ->type_name("ADDR=PROFILE");
    cmd.add_option("--bus", args.bus_file,
                   "A bus file (TOML) listing the devices on the line and, optionally, its "
                   "line settings")
        ->type_name("FILE");
}

void print_problems(const std::vector<ProfileProblem>& problems) {
    for (const ProfileProblem& p : problems) {
        fmt::print(stderr, "rtuscope: error: {}\n", p.to_string());
    }
}

Result<std::unique_ptr<Bus>> build_bus(const BusArgs& args) {
    auto bus = std::make_unique<Bus>();
    std::vector<std::string> files;
    if (!args.profile_dir.empty()) {
        std::error_code ec;
        std::filesystem::directory_iterator it(args.profile_dir, ec);
        if (ec)
            return Error{fmt::format("cannot read the directory: {}", ec.message()),
                         args.profile_dir};
        for (const auto& entry : it) {
            if (entry.path().extension() == ".toml") files.push_back(entry.path().string());
        }
        std::sort(files.begin(), files.end());
    }
    files.insert(files.end(), args.profile_files.begin(), args.profile_files.end());
    bool failed = false;
    for (const std::string& file : files) {
        ProfileLoad load = load_profile_file(file);
        if (!load.problems.empty() || !load.profile) {
            print_problems(load.problems);
            failed = true;
            continue;
        }
        bus->add_profile(std::move(*load.profile));
    }
    // Each mistake has had its own line; an empty message says there is nothing to add.
    if (failed) return Error{""};
    if (!args.bus_file.empty()) {
        if (auto problems = load_bus_file(*bus, args.bus_file); !problems.empty()) {
            print_problems(problems);
            return Error{""};
        }
    }
    return bus;
}

Status assign_devices(Bus& bus, const BusArgs& args) {
    for (const std::string& device : args.devices) {
        if (Status s = assign_device_option(bus, device); !s) return s.error();
    }
    return ok_status();
}

}  // namespace rtuscope::cli
