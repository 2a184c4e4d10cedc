// The options that say which slave is which device, shared by the commands that decode.
#pragma once

#include <CLI/CLI.hpp>
#include <memory>
#include <string>
#include <vector>

#include "profiles/bus.hpp"

namespace rtuscope::cli {

struct BusArgs {
    std::vector<std::string> profile_files;
    std::string profile_dir;
    std::vector<std::string> devices;
    std::string bus_file;
};

// --profile and --profile-dir, and with them --device and --bus.
void add_profile_options(CLI::App& cmd, BusArgs& args);
void add_bus_options(CLI::App& cmd, BusArgs& args);

// The bundled profiles, the user's, and the bus file's map. Problems in profile files and
// the bus file are all printed, one per line (FILE:LINE:COL: message); the result is then
// an error. A file that cannot be read or holds mistakes is exit status 1.
Result<std::unique_ptr<Bus>> build_bus(const BusArgs& args);
// The --device options on top of it. A malformed one or an unknown profile name is a bad
// option: exit status 2.
Status assign_devices(Bus& bus, const BusArgs& args);

// Prints every problem in a profile file, one per line, on stderr.
void print_problems(const std::vector<ProfileProblem>& problems);

}  // namespace rtuscope::cli
