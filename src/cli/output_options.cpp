#include "output_options.hpp"

#include <unistd.h>

#include <cmath>
#include <cstdlib>

#include "errors.hpp"
#include "rtuscope/sinks.hpp"

namespace rtuscope::cli {

void add_output_options(CLI::App& cmd, OutputArgs& args) {
    auto* csv = cmd.add_flag("--csv", args.csv, "Print the per-frame CSV instead of text");
    cmd.add_flag("--values-csv", args.values_csv,
                 "Print one CSV row per register value (needs --device or --bus) instead of "
                 "text")
        ->excludes(csv);
    cmd.add_option("--baud", args.baud, "Line speed; overrides the capture header (default 9600)");
    cmd.add_option("--format", args.format,
                   "Data bits, parity, stop bits: 8N1, 8E1, 8O1, 8N2, 7E1...; overrides the "
                   "capture header (default 8N1)");
    cmd.add_option("--timeout", args.timeout_s,
                   "Seconds after which a request counts as unanswered (default 1)");
    cmd.add_option("-t,--time", args.time_format,
                   "Time column: a = absolute (default), r = relative to the first frame, "
                   "d = delta to the previous frame")
        ->check(CLI::IsMember({"a", "r", "d"}));
    cmd.add_flag("--hex", args.hex, "Show the raw bytes of every frame (text output)");
    cmd.add_flag("--no-color", args.no_color,
                 "No colour (also off when NO_COLOR is set or stdout is not a terminal)");
    add_bus_options(cmd, args.bus);
}

std::optional<Decoding> prepare_decoding(const OutputArgs& args, int& exit_code) {
    Decoding d;
    auto fail = [&](const Error& error, int code) {
        print_error(error);
        exit_code = code;
        return std::nullopt;
    };
    if (!args.baud.empty()) {
        auto baud = parse_baud(args.baud);
        if (!baud) return fail(baud.error(), 2);
        d.options.baud = *baud;
    }
    if (!args.format.empty()) {
        auto format = parse_line_format(args.format);
        if (!format) return fail(format.error(), 2);
        d.options.format = *format;
    }
    if (!(args.timeout_s > 0) || !std::isfinite(args.timeout_s)) {
        return fail(Error{"--timeout must be a positive number of seconds"}, 2);
    }
    d.options.timeout = static_cast<Nanos>(std::llround(args.timeout_s * 1e9));

    auto bus = build_bus(args.bus);
    if (!bus) return fail(bus.error(), 1);
    d.bus = std::move(*bus);
    if (!d.bus->empty()) d.options.bus = d.bus.get();
    if (args.values_csv && d.options.bus == nullptr) {
        return fail(Error{"--values-csv needs to know the devices: --device ADDR=PROFILE or "
                          "--bus FILE"},
                    2);
    }

    if (args.csv) {
        d.sink = make_csv_sink(stdout);
    } else if (args.values_csv) {
        d.sink = make_values_csv_sink(stdout);
    } else {
        TextOptions text;
        text.hex = args.hex;
        text.color = !args.no_color && std::getenv("NO_COLOR") == nullptr && isatty(STDOUT_FILENO);
        text.time_format = args.time_format == "r"   ? TimeFormat::relative
                           : args.time_format == "d" ? TimeFormat::delta
                                                     : TimeFormat::absolute;
        d.sink = make_text_sink(stdout, text);
    }
    return d;
}

LineSettings live_line(const Decoding& decoding) {
    LineSettings line;
    if (decoding.options.bus != nullptr) {
        if (auto bus_line = decoding.options.bus->line()) line = *bus_line;
    }
    if (decoding.options.format) {
        const std::uint32_t baud = line.baud;
        line = *decoding.options.format;
        line.baud = baud;
    }
    if (decoding.options.baud) line.baud = *decoding.options.baud;
    return line;
}

}  // namespace rtuscope::cli
