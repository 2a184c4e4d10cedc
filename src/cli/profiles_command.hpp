// `rtuscope profiles list|show|check`: the device profiles rtuscope knows, one profile's
// register table, and the validation of a profile file.
#pragma once

#include <CLI/CLI.hpp>

namespace rtuscope::cli {

void add_profiles_command(CLI::App& app, int& exit_code);

}  // namespace rtuscope::cli
