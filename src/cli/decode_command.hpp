// `rtuscope decode FILE`: a saved capture, raw dump or hex log, decoded offline.
#pragma once

#include <CLI/CLI.hpp>

namespace rtuscope::cli {

// Adds the subcommand to `app`; it runs when parsed, setting `exit_code`.
void add_decode_command(CLI::App& app, int& exit_code);
// `rtuscope stats FILE`: the same input, counted per slave and function code.
void add_stats_command(CLI::App& app, int& exit_code);

}  // namespace rtuscope::cli
