#include "decode_command.hpp"

#include <fmt/format.h>

#include <memory>
#include <string>

#include "errors.hpp"
#include "input/joined_source.hpp"
#include "output_options.hpp"
#include "telemetry_options.hpp"
#include "stop_signals.hpp"

namespace rtuscope::cli {
namespace {

struct DecodeArgs {
    std::vector<std::string> files;
    std::string input_format = "auto";
    std::vector<std::uint16_t> rtu_ports;
    OutputArgs output;
    TelemetryArgs telemetry;
};

int run_decode(const DecodeArgs& args) {
    InputFormat input_format = InputFormat::automatic;
    if (args.input_format != "auto") {
        auto parsed = parse_input_format(args.input_format);
        if (!parsed) return print_error(parsed.error()), 2;
        input_format = *parsed;
    }
    auto files = expand_inputs(args.files);
    if (!files) return print_error(files.error()), 1;
    auto source = open_joined(*files, input_format, PcapOptions{args.rtu_ports});
    if (!source) return print_error(source.error()), 1;
    const std::string& name = files->size() == 1 ? files->front() : (*source)->info().name;
    // After the input's header is read: it may give the device map.
    int exit_code = 0;
    auto decoding = prepare_decoding(args.output, exit_code, &(*source)->info());
    if (!decoding) return exit_code;
    if (Status bounds = check_time_bounds(*decoding, (*source)->info().time_base); !bounds) {
        return print_error(bounds.error()), 2;
    }

    auto telemetry = attach_telemetry(args.telemetry, name, *decoding, exit_code);
    if (!telemetry) return exit_code;

    // Ctrl-C or SIGTERM stop at a record boundary: every output flushed and closed (the
    // --pcap file too), the summary printed, then the shell's status for the signal.
    install_stop_handlers();
    decoding->options.stop = &g_stop;
    Totals totals;
    const Status status = run_pipeline(**source, decoding->options, *decoding->sink, &totals);
    // The text outputs (decode's, stats') end with their remarks; the others have no
    // place for them.
    if (args.output.csv || args.output.values_csv || args.output.jsonl) {
        for (const std::string& remark : totals.remarks) {
            fmt::print(stderr, "rtuscope: note: {}: {}\n", name, remark);
        }
    }
    const int telemetry_code = finish_telemetry(*telemetry);
    if (!status) return print_error(status.error()), 1;
    if (Status pcap = pcap_status(*decoding); !pcap) return print_error(pcap.error()), 1;
    if (stop_signal() != 0) return 128 + stop_signal();
    return telemetry_code;
}

}  // namespace

void add_stats_command(CLI::App& app, int& exit_code) {
    auto args = std::make_shared<DecodeArgs>();
    args->output.stats = true;
    CLI::App* cmd =
        app.add_subcommand("stats",
                           "Bus statistics of a capture: per slave and function code, turnaround "
                           "percentiles, utilisation, poll cycles");
    cmd->add_option("FILE", args->files,
                    "Input files, read as one stream in the order given ('-' for standard "
                    "input; a quoted pattern such as 'bus-*.rtucap' in name order)")
        ->required();
    cmd->add_option("--input-format", args->input_format,
                    "capture, raw, hex or pcap; default: detected from the content")
        ->check(CLI::IsMember({"auto", "capture", "raw", "hex", "pcap"}));
    add_rtu_port_option(*cmd, args->rtu_ports);
    add_stats_options(*cmd, args->output);
    cmd->callback([args, &exit_code] { exit_code = run_decode(*args); });
}

void add_decode_command(CLI::App& app, int& exit_code) {
    auto args = std::make_shared<DecodeArgs>();
    CLI::App* cmd = app.add_subcommand("decode",
                                       "Decode a saved capture, raw dump, hex log or pcap into "
                                       "annotated text, CSV or JSON Lines");
    cmd->add_option("FILE", args->files,
                    "Input files, read as one stream in the order given ('-' for standard "
                    "input; a quoted pattern such as 'bus-*.rtucap' in name order)")
        ->required();
    cmd->add_option("--input-format", args->input_format,
                    "capture (native text format), raw (bytes, no timing), hex (bytes in hex "
                    "a line at a time) or pcap (pcap/pcapng); default: detected from the "
                    "content")
        ->check(CLI::IsMember({"auto", "capture", "raw", "hex", "pcap"}));
    add_rtu_port_option(*cmd, args->rtu_ports);
    add_output_options(*cmd, args->output);
    add_telemetry_options(*cmd, args->telemetry, false);
    cmd->callback([args, &exit_code] { exit_code = run_decode(*args); });
}

}  // namespace rtuscope::cli
