// rtuscope: a passive Modbus RTU bus analyser. This file only sets up the subcommands;
// the work is in the library, and errors are printed in one place per command.
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <exception>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "decode_command.hpp"
#include "detect_command.hpp"
#include "output/block_output.hpp"
#include "profiles_command.hpp"
#include "report_command.hpp"
#include "sniff_command.hpp"
#include "util/near_names.hpp"
#include "watch_command.hpp"

namespace {

// The command the arguments reached: rtuscope itself, or a command, or `profiles show`.
CLI::App* reached(CLI::App& app) {
    for (CLI::App* sub : app.get_subcommands()) return reached(*sub);
    return &app;
}

// "rtuscope profiles", for messages.
std::string command_line_of(const CLI::App& app) {
    return app.get_parent() == nullptr ? "rtuscope"
                                       : command_line_of(*app.get_parent()) + " " + app.get_name();
}

// A bad command line: one line naming what is wrong, and exit status 2. A command that
// needs one of its own commands and got none or an unknown one says which there are, and
// the nearest to what was typed.
int bad_options(CLI::App& app, const CLI::ParseError& e) {
    CLI::App* command = reached(app);
    const std::vector<CLI::App*> commands = command->get_subcommands({});
    if (!commands.empty() && command->get_subcommands().empty()) {
        std::string names;
        for (const CLI::App* c : commands) names += (names.empty() ? "" : ", ") + c->get_name();
        std::string typed;
        for (const std::string& arg : command->remaining()) {
            if (!arg.empty() && arg[0] != '-') {
                typed = arg;
                break;
            }
        }
        if (typed.empty()) {
            const std::vector<std::string> left = command->remaining();
            if (!left.empty()) {
                fmt::print(stderr, "rtuscope: error: unknown option \"{}\" ({} --help)\n",
                           left.front(), command_line_of(*command));
                return 2;
            }
            fmt::print(stderr, "rtuscope: error: {} needs a command: {} ({} --help)\n",
                       command_line_of(*command), names, command_line_of(*command));
            return 2;
        }
        const CLI::App* nearest = nullptr;
        std::size_t best = 3;  // at most 2 edits away, or a prefix
        for (const CLI::App* c : commands) {
            const std::size_t d =
                c->get_name().rfind(typed, 0) == 0 ? 0 : rtuscope::edit_distance(typed, c->get_name());
            if (d < best) {
                best = d;
                nearest = c;
            }
        }
        fmt::print(stderr, "rtuscope: error: unknown command \"{}\" ({}: {}){}\n", typed,
                   command_line_of(*command), names,
                   nearest != nullptr ? fmt::format("; did you mean \"{}\"?", nearest->get_name())
                                      : std::string());
        return 2;
    }
    fmt::print(stderr, "rtuscope: error: {} ({} --help)\n", e.what(), command_line_of(*command));
    return 2;
}

int run(int argc, char** argv) {
    CLI::App app{
        "rtuscope: a passive Modbus RTU bus analyser. It frames, CRC-checks, pairs and "
        "decodes the traffic of an RS-485 line, and never transmits."};
    app.set_version_flag("--version", "rtuscope " RTUSCOPE_VERSION);
    app.require_subcommand(1);
    int exit_code = 0;
    rtuscope::cli::add_decode_command(app, exit_code);
    rtuscope::cli::add_stats_command(app, exit_code);
    rtuscope::cli::add_report_command(app, exit_code);
    rtuscope::cli::add_sniff_command(app, exit_code);
    rtuscope::cli::add_demo_command(app, exit_code);
    rtuscope::cli::add_watch_command(app, exit_code);
    rtuscope::cli::add_detect_command(app, exit_code);
    rtuscope::cli::add_profiles_command(app, exit_code);
    try {
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForVersion& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        return bad_options(app, e);
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
