// `rtuscope profiles infer`: a draft profile of each slave, inferred from a capture's
// traffic (src/infer/).
#pragma once

#include <CLI/CLI.hpp>

namespace rtuscope::cli {

// Adds `infer` to the `profiles` command.
void add_infer_command(CLI::App& profiles, int& exit_code);

}  // namespace rtuscope::cli
