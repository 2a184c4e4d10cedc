// rtuscope: a passive Modbus RTU bus analyser. This file only sets up the subcommands;
// the work is in the library, and errors are printed in one place per command.
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <exception>
#include <stdexcept>

#include "decode_command.hpp"
#include "output/block_output.hpp"
#include "profiles_command.hpp"
#include "sniff_command.hpp"

namespace {

int run(int argc, char** argv) {
    CLI::App app{
        "rtuscope: a passive Modbus RTU bus analyser. It frames, CRC-checks, pairs and "
        "decodes the traffic of an RS-485 line, and never transmits."};
    app.set_version_flag("--version", "rtuscope " RTUSCOPE_VERSION);
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

// What stdio still holds is written now, while a failure can be reported: a full disk
// must not pass for a complete output with exit status 0. (The sinks' own blocks stop
// the run at the first refused write; this catches what went through stdio alone.) A
// refused flush throws, as in the sinks; a write refused where nothing could throw (an
// output block's destructor) is left in the file's error indicator.
int with_output_written(int exit_code) {
    rtuscope::flush_output(stdout);
    if (std::ferror(stdout) != 0) throw std::runtime_error("cannot write the output: write error");
    return exit_code;
}

}  // namespace

// Nothing may escape main: an exception anywhere (out of memory, a library's) ends with
// one line on stderr and exit status 1, never with std::terminate's abort.
int main(int argc, char** argv) {
    try {
        return with_output_written(run(argc, argv));
    } catch (const std::exception& e) {
        std::fprintf(stderr, "rtuscope: error: %s\n", e.what());
    } catch (...) {
        std::fprintf(stderr, "rtuscope: error: unexpected internal error\n");
    }
    return 1;
}
