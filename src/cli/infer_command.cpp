#include "infer_command.hpp"

#include <fmt/format.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "errors.hpp"
#include "infer/poll_map.hpp"
#include "infer/profile_writer.hpp"
#include "infer/scoring.hpp"
#include "input/joined_source.hpp"
#include "output/filter.hpp"
#include "output_options.hpp"

namespace rtuscope::cli {
namespace {

struct InferArgs {
    std::vector<std::string> files;
    std::string input_format = "auto";
    std::vector<std::uint16_t> rtu_ports;
    std::string baud;
    std::string format;
    double timeout_s = 1.0;
    std::vector<std::string> slaves;
    std::string out_dir;
};

// Every record into the poll map; nothing printed.
class PollMapSink final : public RecordSink {
  public:
    explicit PollMapSink(infer::PollMapBuilder& builder) : builder_(builder) {}
    void begin(const SessionInfo& /*session*/) override {}
    void record(const Record& record) override { builder_.add(record); }
    void end(const Totals& /*totals*/, const std::vector<std::string>& /*remarks*/) override {}

  private:
    infer::PollMapBuilder& builder_;
};

bool selected(const RecordFilter::Ranges& ranges, unsigned slave) {
    if (ranges.empty()) return true;
    for (const auto& [first, last] : ranges) {
        if (slave >= first && slave <= last) return true;
    }
    return false;
}

Status write_file(const std::string& path, const std::string& text) {
    std::FILE* f = std::fopen(path.c_str(), "w");
    if (f == nullptr) return Error{fmt::format("cannot write: {}", std::strerror(errno)), path};
    const bool written = std::fwrite(text.data(), 1, text.size(), f) == text.size();
    if (std::fclose(f) != 0 || !written) {
        return Error{fmt::format("cannot write: {}", std::strerror(errno)), path};
    }
    return ok_status();
}

int run_infer(const InferArgs& args) {
    InputFormat input_format = InputFormat::automatic;
    if (args.input_format != "auto") {
        auto parsed = parse_input_format(args.input_format);
        if (!parsed) return print_error(parsed.error()), 2;
        input_format = *parsed;
    }
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
        return print_error(Error{"--timeout must be a positive number of seconds"}), 2;
    }
    options.timeout = static_cast<Nanos>(std::llround(args.timeout_s * 1e9));
    RecordFilter::Ranges slaves;
    for (const std::string& text : args.slaves) {
        auto r = parse_ranges(text, 255);
        if (!r) return print_error(Error{"--slave: " + r.error().message}), 2;
        slaves.insert(slaves.end(), r->begin(), r->end());
    }

    auto files = expand_inputs(args.files);
    if (!files) return print_error(files.error()), 1;
    auto source = open_joined(*files, input_format, PcapOptions{args.rtu_ports});
    if (!source) return print_error(source.error()), 1;
    const std::string name = files->size() == 1 ? files->front() : (*source)->info().name;

    infer::PollMapBuilder builder;
    PollMapSink sink(builder);
    const Status status = run_pipeline(**source, options, sink);
    if (!status) return print_error(status.error()), 1;

    std::vector<infer::DeviceGuess> devices;
    for (const auto& [address, traffic] : builder.slaves()) {
        if (!selected(slaves, address)) continue;
        if (traffic.answered_reads == 0 && traffic.writes.empty()) continue;
        devices.push_back(infer::infer_device(traffic));
    }
    std::uint64_t answered = 0;
    for (const infer::DeviceGuess& d : devices) answered += d.answered_reads;
    if (answered == 0) {
        print_error(Error{fmt::format("no answered reads (function 01-04){}: nothing to infer a "
                                      "profile from",
                                      slaves.empty() ? "" : " of the slaves given"),
                          name});
        return 1;
    }
    std::erase_if(devices, [](const infer::DeviceGuess& d) { return d.answered_reads == 0; });
    const std::string source_name = std::filesystem::path(name).filename().string();
    if (args.out_dir.empty()) {
        if (devices.size() > 1) {
            std::string list;
            for (const infer::DeviceGuess& d : devices) {
                list += fmt::format("{}{}", list.empty() ? "" : ", ", d.slave);
            }
            print_error(Error{fmt::format("slaves {} answered: a profile is of one device; "
                                          "give --slave N for one on stdout, or -o DIR for "
                                          "one file per slave",
                                          list),
                              name});
            return 2;
        }
        fmt::print("{}", infer::write_profile(devices.front(), source_name));
        return 0;
    }
    std::error_code ec;
    std::filesystem::create_directories(args.out_dir, ec);
    if (ec) {
        return print_error(Error{fmt::format("cannot create the directory: {}", ec.message()),
                                 args.out_dir}),
               1;
    }
    for (const infer::DeviceGuess& d : devices) {
        const std::string path =
            (std::filesystem::path(args.out_dir) / (infer::draft_profile_name(d.slave) + ".toml"))
                .string();
        if (Status s = write_file(path, infer::write_profile(d, source_name)); !s) {
            return print_error(s.error()), 1;
        }
        fmt::print("{}: slave {}, {} registers\n", path, d.slave, d.registers.size());
    }
    return 0;
}

}  // namespace

void add_infer_command(CLI::App& profiles, int& exit_code) {
    auto args = std::make_shared<InferArgs>();
    CLI::App* cmd = profiles.add_subcommand(
        "infer",
        "Infer a draft profile from a capture: the poll map and each register's type, word "
        "order and access, with the evidence as comments");
    cmd->add_option("FILE", args->files,
                    "Input files, read as one stream in the order given ('-' for standard "
                    "input; a quoted pattern such as 'bus-*.rtucap' in name order)")
        ->required();
    cmd->add_option("--slave", args->slaves,
                    "Only these slave addresses, e.g. 3 or 1,3,10-20; repeatable. Without "
                    "-o, one slave: its profile goes to stdout")
        ->type_name("LIST");
    cmd->add_option("-o,--output-dir", args->out_dir,
                    "Write one profile per slave into DIR, as slave-N.toml")
        ->type_name("DIR");
    cmd->add_option("--input-format", args->input_format,
                    "capture, raw, hex or pcap; default: detected from the content")
        ->check(CLI::IsMember({"auto", "capture", "raw", "hex", "pcap"}));
    add_rtu_port_option(*cmd, args->rtu_ports);
    cmd->add_option("--baud", args->baud, "Line speed; overrides the capture header (default 9600)");
    cmd->add_option("--format", args->format,
                    "Data bits, parity, stop bits: 8N1, 8E1, ...; overrides the capture header");
    cmd->add_option("--timeout", args->timeout_s,
                    "Seconds after which a request counts as unanswered (default 1)");
    cmd->callback([args, &exit_code] { exit_code = run_infer(*args); });
}

}  // namespace rtuscope::cli
