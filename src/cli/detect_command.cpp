#include "detect_command.hpp"

#include <fmt/format.h>
#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "errors.hpp"
#include "framing/char_time.hpp"
#include "input/sources.hpp"
#include "input/tty_listener.hpp"
#include "sim/sim.hpp"
#include "sniff_command.hpp"
#include "stop_signals.hpp"
#include "util/text.hpp"

namespace rtuscope::cli {
namespace {

struct DetectArgs {
    std::vector<std::string> inputs;
    bool demo = false;
    std::string demo_line = "19200 8E1";
    std::vector<std::string> bauds;
    bool all_formats = false;
    double max_seconds = 120;
};

bool is_port(const std::string& path) {
    struct stat st {};
    return stat(path.c_str(), &st) == 0 && S_ISCHR(st.st_mode);
}

// `before_listening`: told each setting before the ports are set to it (the demo's bus,
// which a pseudo-terminal cannot tell the format).
Result<DetectResult> listen_to_ports(
    const std::vector<std::string>& ports, const DetectOptions& options,
    const std::function<void(const LineSettings&)>& before_listening = {}) {
    std::vector<std::string> notices;
    auto listener = TtyListener::open(ports, &notices);
    if (!listener) return listener.error();
    for (const std::string& notice : notices) fmt::print(stderr, "rtuscope: note: {}\n", notice);
    return detect_line(
        [&](const LineSettings& line, Nanos most, const auto& enough, std::vector<Chunk>& out) {
            if (before_listening) before_listening(line);
            return (*listener)->listen(line, most, enough, out, options.stop);
        },
        options);
}

std::string joined(const std::vector<std::string>& ports) {
    std::string out;
    for (const std::string& p : ports) out += (out.empty() ? "" : " ") + p;
    return out;
}

int detect_ports(const std::vector<std::string>& ports, DetectOptions options,
                 double max_seconds,
                 const std::function<void(const LineSettings&)>& before_listening = {}) {
    install_stop_handlers();
    options.stop = &g_stop;
    fmt::print(stderr,
               "rtuscope: listening to {} at up to {} settings, for at most {:.0f} s; nothing is "
               "sent\n",
               joined(ports), options.bauds.size() * options.formats.size(), max_seconds);
    auto result = listen_to_ports(ports, options, before_listening);
    if (!result) return print_error(result.error()), 1;
    fmt::print("{}", format_detect_result(*result));
    if (result->alike == 0) return 1;
    fmt::print("Use: rtuscope sniff {} {}\n", joined(ports), line_options(result->chosen));
    return 0;
}

// The seed devices on a virtual bus at a setting detect is not told: its sniffer port
// gets what a UART at each candidate setting would receive.
int detect_demo(const DetectArgs& args, const DetectOptions& options) {
    auto line = parse_line_settings(args.demo_line);
    if (!line) return print_error(line.error()), 2;
    return with_demo_bus(*line, [&](sim::VirtualBus& bus, const std::string& port) {
        return detect_ports({port}, options, args.max_seconds, [&](const LineSettings& candidate) {
            bus.set_receiver_format(kDemoSniffer, candidate.data_bits, candidate.parity);
        });
    });
}

// A capture's timing: bytes timed one by one give the character time; the bytes
// themselves were read at the settings they were recorded at and cannot be read again
// at others.
int detect_file(const std::string& path) {
    auto source = open_source(path, InputFormat::automatic);
    if (!source) return print_error(source.error()), 1;
    const SourceInfo& info = (*source)->info();
    std::vector<Chunk> chunks;
    CharTimeEstimator estimator;
    for (;;) {
        Chunk chunk;
        auto more = (*source)->next(chunk);
        if (!more) return print_error(more.error()), 1;
        if (!*more) break;
        estimator.chunk(chunk);
        chunks.push_back(std::move(chunk));
    }
    std::uint64_t bytes = 0;
    for (const Chunk& c : chunks) bytes += c.bytes.size();
    fmt::print("{}: {} {}, {}\n", path, bytes, plural(bytes, "byte", "bytes"),
               info.line ? fmt::format("recorded at {} {}", info.line->baud, info.line->format())
                         : std::string("its line settings not recorded"));
    const auto estimate = estimator.estimate();
    std::optional<LineSettings> suggested;
    if (!estimate) {
        fmt::print("Its bytes are not timed one by one ({}): the character time cannot be read "
                   "from them. A recording cannot be read again at another rate; to find a "
                   "line's settings, listen to it: rtuscope detect PORT.\n",
                   !info.timed ? "no times at all" : "they were timed in batches");
    } else {
        const auto fits = fit_char_time(estimate->char_time);
        fmt::print("Character time: {:.3f} ms, kept by {} of the {} intervals between bytes "
                   "timed one by one.\n",
                   static_cast<double>(estimate->char_time) / 1e6, estimate->intervals,
                   estimate->measured);
        if (fits.empty()) {
            fmt::print("It fits no standard rate at 10 to 12 bits a character.\n");
        } else {
            const CharTimeFit& fit = fits.front();
            fmt::print("It fits {} baud with {}.\n", fit.baud, describe_char_bits(fit.bits_per_char));
            LineSettings line = info.line.value_or(LineSettings{});
            line.baud = fit.baud;
            suggested = line;
            if (info.line && info.line->baud != fit.baud) {
                fmt::print("The header says {} baud: its timing contradicts it.\n", info.line->baud);
            } else if (info.line && info.line->bits_per_char() != fit.bits_per_char) {
                fmt::print("The header's {} has {}-bit characters: the bytes keep {} bits apart "
                           "(a sender pausing between characters, or another format).\n",
                           info.line->format(), info.line->bits_per_char(), fit.bits_per_char);
            }
        }
    }
    if (info.line) {
        // How the bytes read at the settings they were recorded at.
        const SettingScore s = score_setting(*info.line, chunks, 0, true);
        fmt::print("At {} {}: {} {} with a valid CRC hold {:.0f} % of the bytes, {}.\n",
                   info.line->baud, info.line->format(), s.frames,
                   plural(s.frames, "frame", "frames"), 100.0 * s.coverage(),
                   answers_paired(s.paired));
    }
    if (suggested && (!info.line || info.line->baud != suggested->baud)) {
        fmt::print("Use: rtuscope decode {} --baud {}\n", path, suggested->baud);
    }
    return estimate ? 0 : 1;
}

Result<std::vector<std::uint32_t>> parse_bauds(const std::vector<std::string>& texts) {
    std::vector<std::uint32_t> bauds;
    for (const std::string& text : texts) {
        auto baud = parse_baud(text);
        if (!baud) return baud.error();
        if (std::find(bauds.begin(), bauds.end(), *baud) == bauds.end()) bauds.push_back(*baud);
    }
    return bauds;
}

int run_detect(const DetectArgs& args) {
    DetectOptions options;
    options.formats = default_formats(args.all_formats);
    options.max_total = static_cast<Nanos>(std::llround(args.max_seconds * 1e9));
    options.quiet_wait = std::min(options.quiet_wait, options.max_total);
    if (!args.bauds.empty()) {
        auto bauds = parse_bauds(args.bauds);
        if (!bauds) return print_error(bauds.error()), 2;
        options.bauds = *bauds;
    }
    if (args.demo == !args.inputs.empty()) {
        print_error(Error{"detect takes a port, two ports, a capture file, or --demo"});
        return 2;
    }
    if (args.demo) return detect_demo(args, options);
    const bool ports = std::any_of(args.inputs.begin(), args.inputs.end(), is_port);
    if (ports) return detect_ports(args.inputs, options, args.max_seconds);
    if (args.inputs.size() != 1) {
        print_error(Error{"detect takes one capture file, or one or two serial ports"});
        return 2;
    }
    return detect_file(args.inputs.front());
}

}  // namespace

void add_detect_command(CLI::App& app, int& exit_code) {
    auto args = std::make_shared<DetectArgs>();
    CLI::App* cmd = app.add_subcommand(
        "detect",
        "Find a line's baud rate, parity and stop bits by listening (never transmitting), or "
        "a capture's rate from its byte timing");
    cmd->add_option("INPUT", args->inputs,
                    "Serial port (two for a full-duplex tap), or a capture file")
        ->expected(0, 2);
    cmd->add_flag("--demo", args->demo,
                  "Detect the simulated seed devices' line on a virtual bus (no hardware)");
    cmd->add_option("--demo-line", args->demo_line,
                    "The demo bus's baud rate and format, for detect to find (default "
                    "\"19200 8E1\")");
    cmd->add_option("--bauds", args->bauds,
                    "Baud rates to try, in order (default 9600,19200,115200,38400,57600,4800,"
                    "2400,14400,1200)")
        ->delimiter(',')
        ->type_name("LIST");
    cmd->add_flag("--all-formats", args->all_formats,
                  "Also try 7-bit formats and 2 stop bits with parity (default 8N1, 8E1, 8O1, 8N2)");
    cmd->add_option("--max-seconds", args->max_seconds,
                    "Listen for at most this long in all (default 120)")
        ->check(CLI::PositiveNumber);
    cmd->callback([args, &exit_code] { exit_code = run_detect(*args); });
}

std::optional<LineSettings> detect_for_sniffing(const std::vector<std::string>& ports,
                                                const std::optional<LineSettings>& format,
                                                int& exit_code) {
    DetectOptions options;
    if (format) options.formats = {*format};
    options.stop = &g_stop;
    fmt::print(stderr, "rtuscope: --baud auto: listening to {} to find its settings\n",
               joined(ports));
    auto result = listen_to_ports(ports, options);
    if (!result) {
        print_error(result.error());
        exit_code = 1;
        return std::nullopt;
    }
    if (result->alike == 0) {
        fmt::print(stderr, "{}", format_detect_result(*result));
        print_error(Error{result->quiet ? "--baud auto: the line is quiet, nothing to detect"
                                        : "--baud auto: no setting reads this line as Modbus RTU"});
        exit_code = 1;
        return std::nullopt;
    }
    for (const std::string& line : detect_verdict(*result)) {
        fmt::print(stderr, "rtuscope: note: {}\n", line);
    }
    return result->chosen;
}

}  // namespace rtuscope::cli
