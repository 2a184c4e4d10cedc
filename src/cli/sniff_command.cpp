#include "sniff_command.hpp"

#include <fmt/format.h>
#include <syslog.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "detect_command.hpp"
#include "errors.hpp"
#include "input/capture_writer.hpp"
#include "recording/recorder.hpp"
#include "input/tty.hpp"
#include "output/trigger.hpp"
#include "stats/health.hpp"
#include "util/output_file.hpp"
#include "output_options.hpp"
#include "report_command.hpp"
#include "sim/sim.hpp"
#include "stop_signals.hpp"
#include "util/text.hpp"

namespace rtuscope::cli {
namespace {

void add_live_options(CLI::App& cmd, LiveArgs& args) {
    add_recording_options(cmd, args);
    add_output_options(cmd, args.output);
    add_telemetry_options(cmd, args.telemetry);
}

}  // namespace

void add_recording_options(CLI::App& cmd, LiveArgs& args) {
    cmd.add_option("-w,--write", args.write_file,
                   "Also record the raw chunks to FILE in the native capture format; FILE.zst "
                   "or FILE.gz compressed")
        ->type_name("FILE");
    cmd.add_option("--rotate-size", args.rotate_megabytes,
                   "Start a new -w file before one grows past this many MB (10^6 bytes); "
                   "names get their start time")
        ->type_name("MB")
        ->check(CLI::PositiveNumber);
    cmd.add_option("--rotate-seconds", args.rotate_seconds,
                   "Start a new -w file every S seconds, on multiples of S since midnight UTC")
        ->type_name("S")
        ->check(CLI::PositiveNumber);
    cmd.add_option("--rotate-files", args.rotate_files,
                   "Keep only the newest N -w files, removing older ones (a ring)")
        ->type_name("N")
        ->check(CLI::PositiveNumber);
    cmd.add_option("--trigger", args.triggers,
                   "With -w, write only windows around the records EXPR picks (repeatable: any "
                   "one fires), e.g. flag=txn.no_answer, 'slave=3,crc=bad', 'voltage>250'")
        ->type_name("EXPR");
    cmd.add_option("--pre", args.pre_seconds,
                   "Seconds of the line before an event that its window holds (default 10)")
        ->type_name("S")
        ->check(CLI::NonNegativeNumber);
    cmd.add_option("--pre-bytes", args.pre_megabytes,
                   "At most this many MB of the line held in memory for --pre (default 64)")
        ->type_name("MB")
        ->check(CLI::PositiveNumber);
    cmd.add_option("--post", args.post_seconds,
                   "Seconds after the last event that its window holds (default 10)")
        ->type_name("S")
        ->check(CLI::NonNegativeNumber);
    cmd.add_option("--seconds", args.seconds, "Stop after this many seconds (default: Ctrl-C)")
        ->check(CLI::PositiveNumber);
    cmd.add_flag("--syslog", args.syslog,
                 "Send the daily health line (each local day's counts, at midnight) to syslog "
                 "rather than to stderr");
    add_report_options(cmd, args.report_file, args.report_flagged,
                       "Write the bus as one HTML page to FILE (charts, statistics, flagged "
                       "records; docs/report.md) at the end of the run and on SIGUSR1");
    cmd.add_flag("--reopen", args.reopen,
                 "When the port goes away (an adapter unplugged), wait for it and open it again "
                 "with the same settings, noting the gap, rather than ending with status 1");
}

namespace {

RecordingOptions recording_options(const LiveArgs& args, const Decoding& decoding) {
    RecordingOptions options;
    if (!args.triggers.empty()) {
        TriggerWindows windows;
        if (args.pre_seconds) windows.pre = static_cast<Nanos>(std::llround(*args.pre_seconds * 1e9));
        if (args.post_seconds) windows.post = static_cast<Nanos>(std::llround(*args.post_seconds * 1e9));
        if (args.pre_megabytes) {
            windows.pre_bytes = static_cast<std::size_t>(std::llround(*args.pre_megabytes * 1e6));
        }
        // A request's record is decided when its answer comes or the timeout passes,
        // and the line's silence after it ends the frame.
        windows.decision_delay = decoding.options.timeout + kNanosPerSecond;
        options.windows = windows;
    }
    options.path = args.write_file;
    options.file.compression = compression_for(args.write_file);
    options.rotation.max_bytes = static_cast<std::uint64_t>(std::llround(args.rotate_megabytes * 1e6));
    options.rotation.period = static_cast<Nanos>(std::llround(args.rotate_seconds * 1e9));
    options.rotation.keep_files = args.rotate_files;
    options.rotation.rotate_now = &g_rotate;
    return options;
}

// "rtuscope: recorded 12 files, the last bus-20261128T030000Z.rtucap; 3 trigger events,
// 2 windows" when the names are not the one -w gave.
void print_recording_summary(const Recorder& recorder, const LiveArgs& args) {
    const RecordingCounts counts = recorder.counts();
    if (counts.last_file == args.write_file && !recorder.triggered()) return;
    std::string text = counts.files == 0 ? std::string("recorded no file")
                                         : fmt::format("recorded {} {}, the last {}", counts.files,
                                                       plural(counts.files, "file", "files"),
                                                       counts.last_file);
    if (recorder.triggered()) {
        text += fmt::format("; {} trigger {}, {} {}", counts.events,
                            plural(counts.events, "event", "events"), counts.windows,
                            plural(counts.windows, "window", "windows"));
    }
    fmt::print(stderr, "rtuscope: {}\n", text);
}

HealthOptions health_options(const LiveArgs& args, const std::shared_ptr<Recorder>& recorder) {
    HealthOptions options;
    if (args.syslog) {
        openlog("rtuscope", LOG_PID, LOG_DAEMON);
        options.emit = [](const std::string& line) { ::syslog(LOG_INFO, "%s", line.c_str()); };
    } else {
        options.emit = [](const std::string& line) { fmt::print(stderr, "rtuscope: {}\n", line); };
    }
    if (recorder) {
        options.extra = [recorder] { return recording_text(recorder->counts(), recorder->triggered()); };
    }
    return options;
}

}  // namespace

Status check_recording_options(const LiveArgs& args) {
    if (args.write_file.empty() &&
        (args.rotate_megabytes > 0 || args.rotate_seconds > 0 || args.rotate_files > 0)) {
        return Error{"--rotate-size, --rotate-seconds and --rotate-files need -w FILE"};
    }
    if (args.write_file.empty() && !args.triggers.empty()) {
        return Error{"--trigger needs -w FILE: the windows around events are written there"};
    }
    if (args.triggers.empty() && (args.pre_seconds || args.pre_megabytes || args.post_seconds)) {
        return Error{"--pre, --pre-bytes and --post need --trigger"};
    }
    return ok_status();
}

Status check_replay_options(const LiveArgs& args) {
    if (Status s = check_recording_options(args); !s) return s;
    const char* option = !args.write_file.empty() ? "-w"
                         : args.seconds > 0       ? "--seconds"
                         : args.syslog            ? "--syslog"
                         : args.reopen            ? "--reopen"
                                                  : nullptr;
    if (option == nullptr) return ok_status();
    return Error{fmt::format("{} is for a live port (sniff, watch PORT); a file is a recording "
                             "already: rtuscope decode FILE --from T --to T cuts it",
                             option)};
}

void take_baud_auto(LiveArgs& args) {
    if (args.output.baud != "auto") return;
    args.output.baud.clear();
    args.detect_line = true;
}

std::optional<int> detect_if_asked(const LiveArgs& args, Decoding& decoding,
                                   const std::vector<std::string>& ports) {
    if (!args.detect_line) return std::nullopt;
    int code = 0;
    const auto found = detect_for_sniffing(ports, decoding.options.format, code);
    if (!found) return code;
    // Stopped while detecting: the run ends as a stopped sniff does.
    if (g_stop.load()) return 0;
    decoding.options.baud = found->baud;
    decoding.options.format = *found;
    return std::nullopt;
}

int run_live(const LiveArgs& args, Decoding& decoding, TtyOptions tty) {
    std::vector<Trigger> triggers;
    for (const std::string& expression : args.triggers) {
        auto parsed = parse_trigger(expression, trigger_context(decoding.bus.get()));
        if (!parsed) return print_error(Error{"--trigger: " + parsed.error().message}), 2;
        triggers.push_back(std::move(*parsed));
    }
    tty.line = live_line(decoding);
    tty.stop = &g_stop;
    tty.reopen = args.reopen;
    tty.on_notice = [](const std::string& notice) {
        fmt::print(stderr, "rtuscope: note: {}\n", notice);
    };
    if (args.seconds > 0) tty.duration = static_cast<Nanos>(std::llround(args.seconds * 1e9));
    std::vector<std::string> notices;
    auto source = open_tty_source(tty, &notices);
    if (!source) return print_error(source.error()), 1;
    for (const std::string& notice : notices) fmt::print(stderr, "rtuscope: note: {}\n", notice);
    std::unique_ptr<ChunkSource> input = std::move(*source);
    std::shared_ptr<Recorder> recorder;
    if (!args.write_file.empty()) {
        recorder = std::make_shared<Recorder>(
            recording_options(args, decoding), capture_header(live_capture_header(decoding, input->info())));
        if (Status s = recorder->open(clock_ns(CLOCK_REALTIME)); !s) return print_error(s.error()), 1;
        input = record_chunks(std::move(input), recorder);
        if (args.on_recording) {
            args.on_recording([recorder] {
                return recording_text(recorder->counts(), recorder->triggered());
            });
        }
    }
    if (recorder && !triggers.empty()) {
        // Ahead of the output's filters: an event is one whether it is shown or not.
        auto on_event = [recorder, &triggers](const Record& record, std::size_t index) {
            recorder->event(record.frame.start, record.frame.end,
                            fmt::format("record {} fired {}", record.number,
                                        triggers[index].expression));
        };
        decoding.sink = make_trigger_sink(triggers, on_event, std::move(decoding.sink));
    }
    decoding.sink = make_health_sink(health_options(args, recorder), std::move(decoding.sink));
    decoding.options.live = true;
    // The port's settings are the line's: a capture header cannot say otherwise here.
    decoding.options.baud = tty.line.baud;
    decoding.options.format = tty.line;

    Totals totals;
    const Status status = run_pipeline(*input, decoding.options, *decoding.sink, &totals);
    fmt::print(stderr, "rtuscope: {}\n", totals_text(totals));
    if (recorder) print_recording_summary(*recorder, args);
    if (!status) return print_error(status.error()), 1;
    if (Status pcap = pcap_status(decoding); !pcap) return print_error(pcap.error()), 1;
    if (Status report = report_status(decoding); !report) return print_error(report.error()), 1;
    return 0;
}

void add_demo_devices(OutputArgs& output) {
    output.bus.devices.insert(output.bus.devices.begin(),
                              {"1=zb-uvi485", "2=sensor-analyser", "3=pdu485", "4=zyi-relay"});
}

int with_demo_bus(const LineSettings& line,
                  const std::function<int(sim::VirtualBus&, const std::string& port)>& body) {
    auto bus = sim::VirtualBus::create(6, {line, true});
    if (!bus) return print_error(bus.error()), 1;
    auto devices = sim::start_seed_devices(**bus, line);
    if (!devices) return print_error(devices.error()), 1;
    // The sniffer opens its port first, so that it hears the master's first request. A
    // jthread: when the run ends by an exception (an output that cannot be written), it
    // is joined on the way out, then the master stopped, as on the normal way.
    std::unique_ptr<sim::Master> master;
    std::jthread starter([&] {
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
        auto started = sim::start_master((*bus)->port_path(0), line, {}, 0, 50);
        if (started) {
            master = std::move(*started);
        } else {
            print_error(started.error());
            g_stop.store(true);
        }
    });
    const int code = body(**bus, (*bus)->port_path(kDemoSniffer));
    starter.join();
    return code;
}

namespace {

struct SniffArgs {
    std::vector<std::string> ports;
    LiveArgs live;
};

int run_sniff(SniffArgs args) {
    args.live.output.closing_stats = true;
    take_baud_auto(args.live);
    if (Status s = check_recording_options(args.live); !s) return print_error(s.error()), 2;
    int exit_code = 0;
    auto decoding = prepare_decoding(args.live.output, exit_code);
    if (!decoding) return exit_code;
    if (!attach_report(*decoding, args.live.report_file, args.live.report_flagged, exit_code)) {
        return exit_code;
    }
    TtyOptions tty;
    tty.ports = args.ports;
    install_stop_handlers();
    if (auto code = detect_if_asked(args.live, *decoding, args.ports)) return *code;
    auto telemetry = attach_telemetry(args.live.telemetry, args.ports.front(), *decoding, exit_code);
    if (!telemetry) return exit_code;
    const int code = run_live(args.live, *decoding, tty);
    return std::max(code, finish_telemetry(*telemetry));
}

struct DemoArgs {
    LiveArgs live;
};

// The four seed devices at 1-4, a master polling them, all on a paced virtual bus; the
// sniffer listens on a port of its own exactly as on a real adapter.
int run_demo(DemoArgs args) {
    args.live.output.closing_stats = true;
    add_demo_devices(args.live.output);
    if (Status s = check_recording_options(args.live); !s) return print_error(s.error()), 2;
    int exit_code = 0;
    auto decoding = prepare_decoding(args.live.output, exit_code);
    if (!decoding) return exit_code;
    if (!attach_report(*decoding, args.live.report_file, args.live.report_flagged, exit_code)) {
        return exit_code;
    }
    install_stop_handlers();
    auto telemetry = attach_telemetry(args.live.telemetry, "demo", *decoding, exit_code);
    if (!telemetry) return exit_code;
    const int code = with_demo_bus(live_line(*decoding), [&](sim::VirtualBus&, const std::string& port) {
        TtyOptions tty;
        tty.ports = {port};
        return run_live(args.live, *decoding, tty);
    });
    return std::max(code, finish_telemetry(*telemetry));
}

}  // namespace

void add_sniff_command(CLI::App& app, int& exit_code) {
    auto args = std::make_shared<SniffArgs>();
    CLI::App* cmd = app.add_subcommand(
        "sniff", "Decode a live RS-485 line (read-only: rtuscope never transmits)");
    cmd->add_option("PORT", args->ports,
                    "Serial port, e.g. /dev/ttyUSB0; two ports for a full-duplex tap (one per "
                    "direction, the first hearing the master)")
        ->required()
        ->expected(1, 2);
    add_live_options(*cmd, args->live);
    cmd->callback([args, &exit_code] { exit_code = run_sniff(*args); });
}

void add_demo_command(CLI::App& app, int& exit_code) {
    auto args = std::make_shared<DemoArgs>();
    CLI::App* cmd = app.add_subcommand(
        "demo",
        "No hardware needed: the four seed devices simulated on a virtual bus with a polling "
        "master, sniffed live");
    add_live_options(*cmd, args->live);
    cmd->callback([args, &exit_code] { exit_code = run_demo(*args); });
}

}  // namespace rtuscope::cli
