#include "decode_command.hpp"

#include <fmt/format.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <memory>
#include <string>

#include "bus_options.hpp"
#include "errors.hpp"
#include "rtuscope/pipeline.hpp"
#include "rtuscope/sinks.hpp"
#include "rtuscope/sources.hpp"

namespace rtuscope::cli {
namespace {

struct DecodeArgs {
    std::string file;
    bool csv = false;
    std::string baud;
    std::string format;
    std::string input_format = "auto";
    double timeout_s = 1.0;
    std::string time_format = "a";
    bool hex = false;
    bool no_color = false;
    bool values_csv = false;
    BusArgs bus;
};

int run_decode(const DecodeArgs& args) {
    PipelineOptions options;
    if (!args.baud.empty()) {
        auto baud = parse_baud(args.baud);
        if (!baud) return print_error(baud.error()), 2;
        options.baud = *baud;
    }
    if (!args.format.empty()) {
        auto format = parse_line_format(args.format);
        if (!format) return print_error(format.error()), 2;
        options.format = *format;
    }
    if (!(args.timeout_s > 0) || !std::isfinite(args.timeout_s)) {
        print_error(Error{"--timeout must be a positive number of seconds"});
        return 2;
    }
    options.timeout = static_cast<Nanos>(std::llround(args.timeout_s * 1e9));

    auto bus = build_bus(args.bus);
    if (!bus) return print_error(bus.error()), 1;
    if (!(*bus)->empty()) options.bus = bus->get();
    if (args.values_csv && options.bus == nullptr) {
        print_error(
            Error{"--values-csv needs to know the devices: --device ADDR=PROFILE or "
                  "--bus FILE"});
        return 2;
    }

    InputFormat input_format = InputFormat::automatic;
    if (args.input_format != "auto") {
        auto parsed = parse_input_format(args.input_format);
        if (!parsed) return print_error(parsed.error()), 2;
        input_format = *parsed;
    }
    auto source = open_source(args.file, input_format);
    if (!source) return print_error(source.error()), 1;

    std::unique_ptr<RecordSink> sink;
    if (args.csv) {
        sink = make_csv_sink(stdout);
    } else if (args.values_csv) {
        sink = make_values_csv_sink(stdout);
    } else {
        TextOptions text;
        text.hex = args.hex;
        text.color = !args.no_color && std::getenv("NO_COLOR") == nullptr && isatty(STDOUT_FILENO);
        text.time_format = args.time_format == "r"   ? TimeFormat::relative
                           : args.time_format == "d" ? TimeFormat::delta
                                                     : TimeFormat::absolute;
        sink = make_text_sink(stdout, text);
    }
    const Status status = run_pipeline(**source, options, *sink);
    if (args.csv || args.values_csv) {
        for (const std::string& remark : (*source)->remarks()) {
            fmt::print(stderr, "rtuscope: note: {}: {}\n", args.file, remark);
        }
    }
    if (!status) return print_error(status.error()), 1;
    return 0;
}

}  // namespace

void add_decode_command(CLI::App& app, int& exit_code) {
    auto args = std::make_shared<DecodeArgs>();
    CLI::App* cmd = app.add_subcommand(
        "decode", "Decode a saved capture, raw dump or hex log into annotated text or CSV");
    cmd->add_option("FILE", args->file, "Input file ('-' for standard input)")->required();
    auto* csv = cmd->add_flag("--csv", args->csv, "Print the per-frame CSV instead of text");
    cmd->add_flag("--values-csv", args->values_csv,
                  "Print one CSV row per register value (needs --device or --bus) instead of "
                  "text")
        ->excludes(csv);
    cmd->add_option("--baud", args->baud,
                    "Line speed; overrides the capture header (default 9600)");
    cmd->add_option("--format", args->format,
                    "Data bits, parity, stop bits: 8N1, 8E1, 8O1, 8N2, 7E1...; overrides the "
                    "capture header (default 8N1)");
    cmd->add_option("--input-format", args->input_format,
                    "capture (native text format), raw (bytes, no timing) or hex (one frame "
                    "per line); default: detected from the content")
        ->check(CLI::IsMember({"auto", "capture", "raw", "hex"}));
    cmd->add_option("--timeout", args->timeout_s,
                    "Seconds after which a request counts as unanswered (default 1)");
    cmd->add_option("-t,--time", args->time_format,
                    "Time column: a = absolute (default), r = relative to the first frame, "
                    "d = delta to the previous frame")
        ->check(CLI::IsMember({"a", "r", "d"}));
    cmd->add_flag("--hex", args->hex, "Show the raw bytes of every frame (text output)");
    cmd->add_flag("--no-color", args->no_color,
                  "No colour (also off when NO_COLOR is set or stdout is not a terminal)");
    add_bus_options(*cmd, args->bus);
    cmd->callback([args, &exit_code] { exit_code = run_decode(*args); });
}

}  // namespace rtuscope::cli
