// The options every decoding command shares (decode, sniff, demo): line settings, the
// output format, pairing timeout and the bus map, and turning them into a pipeline.
#pragma once

#include <CLI/CLI.hpp>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include "bus_options.hpp"
#include "output/filter.hpp"
#include "output/pcap_writer.hpp"
#include "output/pcapng_writer.hpp"
#include "pipeline.hpp"
#include "stats/report.hpp"

namespace rtuscope::report {
class ReportSink;
}

namespace rtuscope::cli {

struct OutputArgs {
    std::string baud;
    std::string format;
    bool csv = false;
    bool values_csv = false;
    bool jsonl = false;
    bool stats = false;          // the stats command: statistics in the chosen format
    bool closing_stats = false;  // sniff/demo: the statistics on stderr at the end
    std::size_t stats_top = kStatsTop;  // text statistics: rows per table (0: all)
    std::string pcap_file;
    std::string pcapng_file;
    std::string slaves;
    std::string functions;
    std::string kinds;
    std::string from;
    std::string to;
    double timeout_s = 1.0;
    std::string time_format = "a";
    bool hex = false;
    bool no_values = false;
    bool no_color = false;
    BusArgs bus;
    std::vector<std::string> quick_types;  // --as SLAVE[:TABLE]:ADDR=TYPE
    bool guess = false;                    // --guess
};

void add_output_options(CLI::App& cmd, OutputArgs& args);
// The text's look: -t, --hex, --no-values, --no-color.
void add_display_options(CLI::App& cmd, OutputArgs& args);
// --rtu-port: a pcap's TCP/UDP ports that carry Modbus RTU whatever they hold.
void add_rtu_port_option(CLI::App& cmd, std::vector<std::uint16_t>& ports);
// watch's: line, timeout, --no-color, bus map.
void add_watch_options(CLI::App& cmd, OutputArgs& args);
// The report command's: line, timeout, filters, bus map.
void add_report_input_options(CLI::App& cmd, OutputArgs& args);
// The statistics command's subset: formats, line, timeout, display, filters, bus map.
void add_stats_options(CLI::App& cmd, OutputArgs& args);

// Everything the options decide, checked; errors are printed here. nullopt then, with
// `exit_code` set (2 for bad options, 1 for bad profile or bus files).
struct Decoding {
    std::unique_ptr<Bus> bus;
    PipelineOptions options;
    std::unique_ptr<RecordSink> sink;
    PcapSink* pcap = nullptr;  // inside `sink`, when --pcap was given
    PcapngSink* pcapng = nullptr;  // inside `sink`, when --pcapng was given
    // --slave, --function, --kind, --from and --to: `sink` has them; a sink added later
    // (--report) takes them too.
    RecordFilter filter;
    report::ReportSink* report = nullptr;  // inside `sink`, when --report was given
    // --from and --to as given, to be checked against the input's times once it is open.
    std::optional<TimeBound> from;
    std::optional<TimeBound> to;
};
// `input`: the opened input's SourceInfo, whose capture header may give the device map and
// profiles (used unless --device or --bus give their own: a note says so).
std::optional<Decoding> prepare_decoding(const OutputArgs& args, int& exit_code,
                                         const SourceInfo* input = nullptr);

// What a `-w` capture's header holds of a live run: the port's line, the program, the
// device map and the profiles that are not bundled (their TOML), so that the capture
// decodes the same later, on any machine.
SourceInfo live_capture_header(const Decoding& decoding, const SourceInfo& live);

// Once the input is open: whether --from and --to can be placed on its times (an Error
// naming the option if not, for exit status 2).
Status check_time_bounds(const Decoding& decoding, TimeBase base);

// After the run: a --pcap or --pcapng file that could not be written is an error.
Status pcap_status(const Decoding& decoding);

// The line settings for a live port: --baud/--format, else the bus map's, else 9600 8N1.
LineSettings live_line(const Decoding& decoding);

}  // namespace rtuscope::cli
