// rtuscope: a passive Modbus RTU bus analyser. This file only sets up the subcommands;
// the work is in the library, and errors are printed in one place per command.
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <exception>

#include "decode_command.hpp"
#include "profiles_command.hpp"
#include "sniff_command.hpp"

namespace {

int run(int argc, char** argv) {
    CLI::App app{
        "rtuscope: a passive Modbus RTU bus analyser. It frames, CRC-checks, pairs and "
        "decodes the traffic of an RS-485 line, and never transmits."};
    app.set_version_flag("--version", "rtuscope 0.1.0");
    app.require_subcommand(1);
    int exit_code = 0;
    rtuscope::cli::add_decode_command(app, exit_code);
    rtuscope::cli::add_stats_command(app, exit_code);
    rtuscope::cli::add_sniff_command(app, exit_code);
    rtuscope::cli::add_demo_command(app, exit_code);
    rtuscope::cli::add_profiles_command(app, exit_code);
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        return app.exit(e);
    }
    return exit_code;
}

}  // namespace

// Nothing may escape main: an exception anywhere (out of memory, a library's) ends with
// one line on stderr and exit status 1, never with std::terminate's abort.
int main(int argc, char** argv) {
    try {
        return run(argc, argv);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "rtuscope: error: %s\n", e.what());
    } catch (...) {
        std::fprintf(stderr, "rtuscope: error: unexpected internal error\n");
    }
    return 1;
}
