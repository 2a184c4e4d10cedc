// `rtuscope report FILE... -o PAGE`: the bus as one self-contained HTML page
// (docs/report.md), and the --report option of sniff, demo and watch.
#pragma once

#include <CLI/CLI.hpp>
#include <string>

#include "output_options.hpp"

namespace rtuscope::cli {

void add_report_command(CLI::App& app, int& exit_code);

// --report FILE (with `help`) and --flagged N.
void add_report_options(CLI::App& cmd, std::string& file, std::size_t& flagged,
                        const std::string& help);

// With a `path`, tees a report sink into `decoding` (behind its filters), writing the
// page at the end and on SIGUSR1. False, with the error printed and `exit_code` set, when
// the page cannot be written there.
bool attach_report(Decoding& decoding, const std::string& path, std::size_t flagged,
                   int& exit_code);

// After the run: a page that could not be written is an error.
Status report_status(const Decoding& decoding);

}  // namespace rtuscope::cli
