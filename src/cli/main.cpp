// rtuscope: a passive Modbus RTU bus analyser. This file only sets up the subcommands;
// the work is in the library, and errors are printed in one place per command.
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <exception>

#include "decode_command.hpp"
#include "profiles_command.hpp"
#include "sniff_command.hpp"

int main(int argc, char** argv) {
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
    } catch (const std::exception& e) {
        fmt::print(stderr, "rtuscope: error: {}\n", e.what());
        return 1;
    }
    return exit_code;
}
