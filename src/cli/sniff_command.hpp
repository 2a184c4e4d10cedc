// `rtuscope sniff PORT [PORT_B]`: a live line decoded as it happens, and `rtuscope demo`:
// the same on a virtual bus of simulated seed devices. The pieces `watch` shares too.
#pragma once

#include <CLI/CLI.hpp>
#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "input/tty.hpp"
#include "output_options.hpp"
#include "telemetry_options.hpp"

namespace rtuscope::sim {
class VirtualBus;
}

namespace rtuscope::cli {

void add_sniff_command(CLI::App& app, int& exit_code);
void add_demo_command(CLI::App& app, int& exit_code);

struct LiveArgs {
    OutputArgs output;
    TelemetryArgs telemetry;
    std::string write_file;
    double rotate_megabytes = 0;  // --rotate-size
    double rotate_seconds = 0;    // --rotate-seconds
    std::size_t rotate_files = 0;  // --rotate-files
    std::vector<std::string> triggers;  // --trigger: -w keeps only windows around events
    std::optional<double> pre_seconds;    // --pre (default 10)
    std::optional<double> pre_megabytes;  // --pre-bytes, in MB (default 64)
    std::optional<double> post_seconds;   // --post (default 10)
    double seconds = 0;  // 0: until stopped
    bool reopen = false;  // --reopen: wait for a port that went away
    bool syslog = false;  // --syslog: the daily health line to syslog, not stderr
    std::string report_file;  // --report: the HTML page, at the end and on SIGUSR1
    std::size_t report_flagged = 100;  // --flagged: records the page lists
    // Given what the recording has done, once -w's recorder exists (watch shows it).
    std::function<void(std::function<std::string()>)> on_recording;
    bool detect_line = false;  // --baud auto: find the settings before sniffing
};
// Takes `--baud auto` out of the output options (which parse a number) into
// `detect_line`.
void take_baud_auto(LiveArgs& args);
// -w and its rotation, and --seconds.
void add_recording_options(CLI::App& cmd, LiveArgs& args);
// An Error for recording options that do not go together (the run exits 2).
Status check_recording_options(const LiveArgs& args);
// As check_recording_options, and an Error for any option that only a live port
// serves (-w, --seconds, --syslog, --reopen): `watch FILE` replays what is recorded.
Status check_replay_options(const LiveArgs& args);

// With detect_line (--baud auto), finds the line's settings by listening (the rate only
// when --format gives the format) and puts them in `decoding`, saying why on stderr;
// the exit status when the run ends there (nothing found, or stopped).
std::optional<int> detect_if_asked(const LiveArgs& args, Decoding& decoding,
                                   const std::vector<std::string>& ports);

// Runs the pipeline on open ports until they go away, --seconds pass or a signal comes;
// a short summary goes to stderr.
int run_live(const LiveArgs& args, Decoding& decoding, TtyOptions tty);

// The demo's devices (the four seed devices at 1-4) in front of the user's --device.
void add_demo_devices(OutputArgs& output);
// Runs `body` on the port of a virtual bus where the simulated seed devices answer a
// polling master (the bus too, for what a port cannot tell it); returns what it returns.
int with_demo_bus(const LineSettings& line,
                  const std::function<int(sim::VirtualBus&, const std::string& port)>& body);
// The demo bus's port that `body` is given.
inline constexpr std::size_t kDemoSniffer = 5;

}  // namespace rtuscope::cli
