// `rtuscope sniff PORT [PORT_B]`: a live line decoded as it happens, and `rtuscope demo`:
// the same on a virtual bus of simulated seed devices.
#pragma once

#include <CLI/CLI.hpp>

namespace rtuscope::cli {

void add_sniff_command(CLI::App& app, int& exit_code);
void add_demo_command(CLI::App& app, int& exit_code);

}  // namespace rtuscope::cli
