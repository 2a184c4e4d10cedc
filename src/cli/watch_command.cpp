#include "watch_command.hpp"

#include <fmt/format.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "errors.hpp"
#include "input/paced_source.hpp"
#include "input/sources.hpp"
#include "sniff_command.hpp"
#include "output/filter.hpp"
#include "report_command.hpp"
#include "stop_signals.hpp"
#include "telemetry_options.hpp"
#include "watch/watch.hpp"

namespace rtuscope::cli {
namespace {

struct WatchArgs {
    std::vector<std::string> inputs;  // ports, or one file
    bool demo = false;
    bool plain = false;
    double interval_s = 5;
    std::string speed = "1";
    std::vector<std::uint16_t> rtu_ports;
    LiveArgs live;
};

bool is_port(const std::string& path) {
    struct stat st {};
    return ::stat(path.c_str(), &st) == 0 && S_ISCHR(st.st_mode);
}

// The display the options and stdout ask for.
std::unique_ptr<Display> make_display(const WatchArgs& args, bool replay) {
    if (args.plain || isatty(STDOUT_FILENO) == 0) {
        return make_plain_display(stdout, static_cast<Nanos>(std::llround(args.interval_s * 1e9)));
    }
    DashboardOptions options;
    options.color = !args.live.output.no_color;
    options.quit = &g_stop;
    options.replay = replay;
    return make_dashboard(options);
}

// The state the display shows, fed by the telemetry sink (whose exporters the options
// may ask for), the pipeline's only sink until the display's joins it.
std::optional<Telemetry> watch_telemetry(const WatchArgs& args, std::string_view input,
                                         Decoding& decoding, int& exit_code) {
    decoding.sink.reset();
    return attach_telemetry(args.live.telemetry, input, decoding, exit_code, true);
}

void add_watch_sink(Decoding& decoding, const Telemetry& telemetry, Display& display) {
    std::vector<std::unique_ptr<RecordSink>> sinks;
    sinks.push_back(std::move(decoding.sink));
    sinks.push_back(std::make_unique<WatchSink>(*telemetry.shared, display));
    decoding.sink = make_tee_sink(std::move(sinks));
}

// A capture, dump, log or pcap replayed at its own pace (or at once with --speed max).
int watch_file(const WatchArgs& args, double speed) {
    if (Status s = check_replay_options(args.live); !s) return print_error(s.error()), 2;
    auto opened = open_source(args.inputs.front(), InputFormat::automatic, PcapOptions{args.rtu_ports});
    if (!opened) return print_error(opened.error()), 1;
    int exit_code = 0;
    auto decoding = prepare_decoding(args.live.output, exit_code, &(*opened)->info());
    if (!decoding) return exit_code;
    std::unique_ptr<ChunkSource> source = std::move(*opened);
    if (speed > 0) source = pace_source(std::move(source), speed);
    // Learning the batching reads ahead: at most 2 s of the file's time, so that the
    // replay's first screen comes soon.
    if (speed > 0) decoding->options.read_ahead_time = 2 * kNanosPerSecond;
    install_stop_handlers();
    decoding->options.stop = &g_stop;
    auto telemetry = watch_telemetry(args, args.inputs.front(), *decoding, exit_code);
    if (!telemetry) return exit_code;
    const std::unique_ptr<Display> display = make_display(args, true);
    add_watch_sink(*decoding, *telemetry, *display);
    if (!attach_report(*decoding, args.live.report_file, args.live.report_flagged, exit_code)) {
        return exit_code;
    }
    const Status status = run_pipeline(*source, decoding->options, *decoding->sink);
    // The display has ended (a dashboard gave the terminal back): the summaries go there.
    const int telemetry_code = finish_telemetry(*telemetry);
    if (!status) return print_error(status.error()), 1;
    if (Status report = report_status(*decoding); !report) return print_error(report.error()), 1;
    if (stop_signal() != 0) return 128 + stop_signal();
    return telemetry_code;
}

int watch_live(WatchArgs args) {
    if (args.demo) add_demo_devices(args.live.output);
    if (!args.demo) take_baud_auto(args.live);
    if (Status s = check_recording_options(args.live); !s) return print_error(s.error()), 2;
    int exit_code = 0;
    auto decoding = prepare_decoding(args.live.output, exit_code);
    if (!decoding) return exit_code;
    install_stop_handlers();
    // Before the dashboard takes the terminal: the verdict is for the user to read.
    if (!args.demo) {
        if (auto code = detect_if_asked(args.live, *decoding, args.inputs)) return *code;
    }
    auto telemetry = watch_telemetry(args, args.demo ? "demo" : args.inputs.front(), *decoding,
                                     exit_code);
    if (!telemetry) return exit_code;
    const std::unique_ptr<Display> display = make_display(args, false);
    add_watch_sink(*decoding, *telemetry, *display);
    if (!attach_report(*decoding, args.live.report_file, args.live.report_flagged, exit_code)) {
        return exit_code;
    }
    args.live.on_recording = [&](std::function<std::string()> status) {
        display->set_recording(std::move(status));
    };
    auto run = [&](std::vector<std::string> ports) {
        TtyOptions tty;
        tty.ports = std::move(ports);
        return run_live(args.live, *decoding, tty);
    };
    const int code = args.demo ? with_demo_bus(live_line(*decoding),
                                               [&](sim::VirtualBus&, const std::string& port) {
                                                   return run({port});
                                               })
                               : run(args.inputs);
    // A live run ends by being stopped: a signal is its normal end, as for sniff.
    return std::max(code, finish_telemetry(*telemetry));
}

int run_watch(WatchArgs args) {
    if (args.demo == !args.inputs.empty()) {
        print_error(Error{"watch takes a port (or two), a file, or --demo"});
        return 2;
    }
    double speed = 0;  // 0: as fast as it reads
    if (args.speed != "max") {
        try {
            std::size_t used = 0;
            speed = std::stod(args.speed, &used);
            if (used != args.speed.size() || !(speed > 0) || !std::isfinite(speed)) throw 0;
        } catch (...) {
            print_error(Error{fmt::format("--speed: '{}' is not a positive number or 'max'",
                                          args.speed)});
            return 2;
        }
    }
    if (!args.demo && !is_port(args.inputs.front())) {
        if (args.inputs.size() > 1) {
            print_error(Error{fmt::format("{} is not a port: watch replays one file at a time",
                                          args.inputs.front())});
            return 2;
        }
        return watch_file(args, speed);
    }
    return watch_live(std::move(args));
}

}  // namespace

void add_watch_command(CLI::App& app, int& exit_code) {
    auto args = std::make_shared<WatchArgs>();
    CLI::App* cmd = app.add_subcommand(
        "watch",
        "The bus's state: every slave and register, live on a terminal dashboard or as text "
        "tables (a port, two ports, a capture replayed, or --demo)");
    cmd->add_option("INPUT", args->inputs,
                    "Serial port(s) as for sniff, or a capture file to replay at its own pace")
        ->expected(0, 2);
    cmd->add_flag("--demo", args->demo,
                  "Watch the simulated seed devices on a virtual bus (no hardware)");
    cmd->add_flag("--plain", args->plain,
                  "Print the tables as text every --interval seconds instead of the dashboard "
                  "(the default when stdout is not a terminal)");
    cmd->add_option("--interval", args->interval_s,
                    "Seconds between the plain tables, on the input's clock (default 5)")
        ->check(CLI::PositiveNumber);
    cmd->add_option("--speed", args->speed,
                    "Replay a file this many times as fast as it was recorded, or 'max' for its "
                    "final state at once (default 1)");
    add_rtu_port_option(*cmd, args->rtu_ports);
    add_recording_options(*cmd, args->live);
    add_watch_options(*cmd, args->live.output);
    add_telemetry_options(*cmd, args->live.telemetry);
    cmd->callback([args, &exit_code] { exit_code = run_watch(*args); });
}

}  // namespace rtuscope::cli
