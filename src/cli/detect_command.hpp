// `rtuscope detect PORT [PORT_B] | FILE`: an unknown line's baud rate and format, found
// by listening (never transmitting), or read from a capture's byte timing.
#pragma once

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "detect/detect.hpp"

namespace rtuscope::cli {

void add_detect_command(CLI::App& app, int& exit_code);

// Detects the settings of live ports for `--baud auto`: says what was chosen and why on
// stderr. An error, or nothing found, is reported and gives nullopt with `exit_code` set.
std::optional<LineSettings> detect_for_sniffing(const std::vector<std::string>& ports,
                                                const std::optional<LineSettings>& format,
                                                int& exit_code);

}  // namespace rtuscope::cli
