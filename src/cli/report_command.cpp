#include "report_command.hpp"

#include <memory>
#include <utility>
#include <vector>

#include "errors.hpp"
#include "input/joined_source.hpp"
#include "output/filter.hpp"
#include "report/html_report.hpp"
#include "stop_signals.hpp"

namespace rtuscope::cli {
namespace {

struct ReportArgs {
    std::vector<std::string> files;
    std::string input_format = "auto";
    std::vector<std::uint16_t> rtu_ports;
    std::string page;
    std::size_t flagged = report::kDefaultFlagged;
    OutputArgs output;
};

int run_report(const ReportArgs& args) {
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
    int exit_code = 0;
    auto decoding = prepare_decoding(args.output, exit_code, &(*source)->info());
    if (!decoding) return exit_code;
    if (Status bounds = check_time_bounds(*decoding, (*source)->info().time_base); !bounds) {
        return print_error(bounds.error()), 2;
    }
    // The page is the only output: the text sink prepare_decoding made has no reader.
    decoding->sink.reset();
    if (!attach_report(*decoding, args.page, args.flagged, exit_code)) return exit_code;

    install_stop_handlers();
    decoding->options.stop = &g_stop;
    const Status status = run_pipeline(**source, decoding->options, *decoding->sink);
    if (!status) return print_error(status.error()), 1;
    if (Status report = report_status(*decoding); !report) return print_error(report.error()), 1;
    if (stop_signal() != 0) return 128 + stop_signal();
    return 0;
}

}  // namespace

void add_report_options(CLI::App& cmd, std::string& file, std::size_t& flagged,
                        const std::string& help) {
    cmd.add_option("--report", file, help)->type_name("FILE");
    cmd.add_option("--flagged", flagged,
                   "Flagged records (with a note) the report page lists, the first N (default 100)")
        ->type_name("N")
        ->check(CLI::NonNegativeNumber);
}

bool attach_report(Decoding& decoding, const std::string& path, std::size_t flagged,
                   int& exit_code) {
    if (path.empty()) return true;
    auto made = report::make_report_sink(path, flagged, &g_report);
    if (!made) {
        print_error(made.error());
        exit_code = 1;
        return false;
    }
    decoding.report = made->get();
    std::unique_ptr<RecordSink> sink = std::move(*made);
    if (!decoding.filter.empty()) sink = make_filter_sink(decoding.filter, std::move(sink));
    if (!decoding.sink) {
        decoding.sink = std::move(sink);
        return true;
    }
    std::vector<std::unique_ptr<RecordSink>> sinks;
    sinks.push_back(std::move(decoding.sink));
    sinks.push_back(std::move(sink));
    decoding.sink = make_tee_sink(std::move(sinks));
    return true;
}

Status report_status(const Decoding& decoding) {
    return decoding.report != nullptr ? decoding.report->status() : ok_status();
}

void add_report_command(CLI::App& app, int& exit_code) {
    auto args = std::make_shared<ReportArgs>();
    CLI::App* cmd = app.add_subcommand(
        "report",
        "The bus as one self-contained HTML page: figures at a glance, anomalies ranked, "
        "timeline, per-slave turnarounds and cycles, register values, flagged records");
    cmd->add_option("FILE", args->files,
                    "Input files, read as one stream in the order given ('-' for standard "
                    "input; a quoted pattern such as 'bus-*.rtucap' in name order)")
        ->required();
    cmd->add_option("-o,--output", args->page, "The HTML page to write")
        ->type_name("FILE")
        ->required();
    cmd->add_option("--input-format", args->input_format,
                    "capture, raw, hex or pcap; default: detected from the content")
        ->check(CLI::IsMember({"auto", "capture", "raw", "hex", "pcap"}));
    add_rtu_port_option(*cmd, args->rtu_ports);
    cmd->add_option("--flagged", args->flagged,
                    "Flagged records (with a note) the page lists, the first N (default 100)")
        ->type_name("N")
        ->check(CLI::NonNegativeNumber);
    add_report_input_options(*cmd, args->output);
    cmd->callback([args, &exit_code] { exit_code = run_report(*args); });
}

}  // namespace rtuscope::cli
