// `rtuscope watch [PORT [PORT_B] | FILE | --demo]`: the bus's live state, full-screen on a
// terminal or as text tables every few seconds.
#pragma once

#include <CLI/CLI.hpp>

namespace rtuscope::cli {

void add_watch_command(CLI::App& app, int& exit_code);

}  // namespace rtuscope::cli
