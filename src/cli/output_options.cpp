#include "output_options.hpp"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <tuple>
#include <utility>

#include "errors.hpp"
#include "output/filter.hpp"
#include "output/sinks.hpp"
#include "profiles/quick_type.hpp"
#include "stats/report.hpp"
#include "util/io_block.hpp"
#include "util/text_file.hpp"

namespace rtuscope::cli {

namespace {

void add_filter_options(CLI::App& cmd, OutputArgs& args) {
    cmd.add_option("--slave", args.slaves, "Only these slave addresses, e.g. 1,3,10-20")
        ->type_name("LIST")
        ->group("Filters");
    cmd.add_option("--function", args.functions,
                   "Only these function codes (exceptions count as their function), e.g. 3,0x10")
        ->type_name("LIST")
        ->group("Filters");
    cmd.add_option("--kind", args.kinds,
                   "Only these kinds: request, response, exception, broadcast, unknown, "
                   "invalid, noise, flagged (any record with a note)")
        ->type_name("LIST")
        ->group("Filters");
    cmd.add_option("--from", args.from,
                   "Only frames starting at or after this time: a time of day as -t a shows "
                   "it (08:00:01.5; on the first frame's day, or the next if earlier), a date "
                   "and time (2026-11-21 08:00:01), seconds as in the CSV time column, or +S "
                   "after the first frame")
        ->type_name("TIME")
        ->group("Filters");
    cmd.add_option("--to", args.to, "Only frames starting at or before this time (as --from)")
        ->type_name("TIME")
        ->group("Filters");
}

void add_line_options(CLI::App& cmd, OutputArgs& args) {
    cmd.add_option("--baud", args.baud,
                   "Line speed; overrides the capture header (default 9600). sniff and watch: "
                   "'auto' finds the speed and format by listening first");
    cmd.add_option("--format", args.format,
                   "Data bits, parity, stop bits: 8N1, 8E1, 8O1, 8N2, 7E1...; overrides the "
                   "capture header (default 8N1)");
    cmd.add_option("--timeout", args.timeout_s,
                   "Seconds after which a request counts as unanswered (default 1)");
}

// The bus map and, on top of it, --as.
void add_device_options(CLI::App& cmd, OutputArgs& args) {
    add_bus_options(cmd, args.bus);
    cmd.add_option("--as", args.quick_types,
                   "Decode one register as TYPE, as a line of a profile would: "
                   "SLAVE[:TABLE]:ADDR=TYPE[/ORDER][*SCALE][:UNIT], e.g. "
                   "247:input:0x4082=f32/cdab or 3:0x0010=u16*0.1:V (TABLE holding, input, "
                   "coil or discrete; default holding). Adds to or overrides the slave's "
                   "profile, or gives a slave without one a profile of these registers; "
                   "repeatable")
        ->type_name("SLAVE[:TABLE]:ADDR=TYPE");
}

// Guesses are shown with the values (text, values CSV, JSONL); `stats` takes the option
// too, so that a decode's command line still works there, and shows no values.
void add_guess_option(CLI::App& cmd, OutputArgs& args) {
    cmd.add_flag("--guess", args.guess,
                 "Show the plausible readings of registers no profile (nor --as) covers: each "
                 "register as u16 (and i16 when negative), each two adjacent registers as "
                 "u32 and f32 in both word orders (abcd, cdab), floats that make no sense "
                 "left out; marked as guesses");
}

TimeFormat time_format(const std::string& letters) {
    if (letters == "ad") return TimeFormat::local_date;
    if (letters == "u") return TimeFormat::utc;
    if (letters == "ud") return TimeFormat::utc_date;
    if (letters == "r") return TimeFormat::relative;
    if (letters == "d") return TimeFormat::delta;
    if (letters == "e") return TimeFormat::epoch;
    return TimeFormat::local;
}

}  // namespace

void add_output_options(CLI::App& cmd, OutputArgs& args) {
    auto* csv = cmd.add_flag("--csv", args.csv, "Print the per-frame CSV instead of text");
    auto* values = cmd.add_flag("--values-csv", args.values_csv,
                                "Print one CSV row per register value (needs --device, --bus, --as "
                                "or --guess) instead of text");
    values->excludes(csv);
    cmd.add_flag("--jsonl", args.jsonl,
                 "Print one JSON object per record (JSON Lines; schema in docs/formats.md)")
        ->excludes(csv)
        ->excludes(values);
    cmd.add_option("--pcap", args.pcap_file,
                   "Also write every frame to FILE as pcap (Wireshark: Modbus RTU, link type 252)")
        ->type_name("FILE");
    cmd.add_option("--pcapng", args.pcapng_file,
                   "Also write every frame to FILE as pcapng: as --pcap, with the direction as "
                   "packet flags, the line, and rtuscope's notes, pairing and values as comments")
        ->type_name("FILE");
    add_line_options(cmd, args);
    add_display_options(cmd, args);
    add_filter_options(cmd, args);
    add_device_options(cmd, args);
    add_guess_option(cmd, args);
}

// The text's look. `stats` takes them too, so that a decode's command line still works
// when `decode` becomes `stats`; they change nothing in the statistics.
void add_display_options(CLI::App& cmd, OutputArgs& args) {
    cmd.add_option("-t,--time", args.time_format,
                   "Time column (text), as tshark's -t: a = local time of day, the date on a "
                   "line of its own when it changes (default; TZ applies), ad = local date "
                   "and time, u/ud = the same in UTC, r = seconds since the first frame, "
                   "d = since the previous frame, e = seconds as in the CSV (epoch); times "
                   "read without a zone show as read")
        ->check(CLI::IsMember({"a", "ad", "u", "ud", "r", "d", "e"}));
    cmd.add_flag("--hex", args.hex, "Show the raw bytes of every frame (text output)");
    cmd.add_flag("--no-values", args.no_values,
                 "Hide the register values under the frames (text output)");
    cmd.add_flag("--no-color", args.no_color,
                 "No colour (also off when NO_COLOR is set or stdout is not a terminal)");
}

void add_stats_options(CLI::App& cmd, OutputArgs& args) {
    auto* csv = cmd.add_flag("--csv", args.csv, "Print the statistics as CSV");
    cmd.add_flag("--jsonl", args.jsonl, "Print the statistics as JSON Lines")->excludes(csv);
    cmd.add_option("--top", args.stats_top,
                   "Rows per table in the text statistics: the busiest N (0: all)")
        ->default_val(kStatsTop)
        ->check(CLI::NonNegativeNumber);
    add_line_options(cmd, args);
    add_display_options(cmd, args);
    add_filter_options(cmd, args);
    add_device_options(cmd, args);
    add_guess_option(cmd, args);
}

void add_report_input_options(CLI::App& cmd, OutputArgs& args) {
    add_line_options(cmd, args);
    add_filter_options(cmd, args);
    add_device_options(cmd, args);
}

void add_rtu_port_option(CLI::App& cmd, std::vector<std::uint16_t>& ports) {
    cmd.add_option("--rtu-port", ports,
                   "pcap: TCP/UDP port whose payloads are Modbus RTU even where no CRC checks "
                   "(a serial gateway's port; its side is the slave's); repeatable. Otherwise "
                   "payloads are told RTU, Modbus/TCP or neither by their content")
        ->type_name("PORT")
        ->check(CLI::Range(1, 65535));
}

void add_watch_options(CLI::App& cmd, OutputArgs& args) {
    add_line_options(cmd, args);
    cmd.add_flag("--no-color", args.no_color, "No colour (also off when NO_COLOR is set)");
    add_device_options(cmd, args);
}

namespace {

// The device map a capture's header gives (and the profiles it embeds), unless --device
// or --bus say otherwise: the options win, and a note says what they replace.
Status use_capture_header(Bus& bus, const SourceInfo& input, const OutputArgs& args) {
    if (input.devices.empty()) return ok_status();
    std::string header_map;
    for (const auto& [address, name] : input.devices) {
        header_map += fmt::format("{}{}={}", header_map.empty() ? "" : ", ", address, name);
    }
    if (!args.bus.devices.empty() || !args.bus.bus_file.empty()) {
        fmt::print(stderr, "rtuscope: note: {}: {} replaces the device map of its header ({})\n",
                   input.name, args.bus.bus_file.empty() ? "--device" : "--bus", header_map);
        return ok_status();
    }
    for (const auto& [name, toml] : input.embedded_profiles) {
        const Profile* known = bus.find_profile(name);
        if (known != nullptr && !known->file.starts_with("<bundled>")) continue;  // --profile
        ProfileLoad load = load_profile_text(toml, input.name + ": profile " + name);
        if (!load.profile) {
            print_problems(load.problems);
            return Error{fmt::format("the profile \"{}\" in its header has mistakes", name),
                         input.name};
        }
        bus.add_profile(std::move(*load.profile));
    }
    for (const auto& [address, name] : input.devices) {
        if (!bus.assign(address, name)) {
            fmt::print(stderr,
                       "rtuscope: note: {}: its header puts the profile \"{}\" on slave {}, "
                       "which this rtuscope does not know: slave {} is decoded without it\n",
                       input.name, name, address, address);
        }
    }
    return ok_status();
}

// Without --device or --bus, a user's profile for one address only (`addresses = [3, 3]`,
// as `profiles infer` writes them) goes on that slave, unless the capture header put
// another there: `decode --profile draft.toml` uses a draft at once.
void assign_one_address_profiles(Bus& bus) {
    for (const Profile* p : bus.profiles()) {
        if (p->file.starts_with("<bundled>") || p->first_address != p->last_address) continue;
        if (bus.profile_for(p->first_address) != nullptr) continue;
        (void)bus.assign(p->first_address, p->name);
    }
}

// --baud or --format over a capture header that gives the line: said, not silent.
void note_line_replaced(const SourceInfo& input, const OutputArgs& args) {
    if (!input.line || (args.baud.empty() && args.format.empty())) return;
    fmt::print(stderr, "rtuscope: note: {}: {} replace{} the line of its header ({} {})\n",
               input.name,
               !args.baud.empty() && !args.format.empty() ? "--baud and --format"
               : !args.baud.empty()                       ? "--baud"
                                                          : "--format",
               !args.baud.empty() && !args.format.empty() ? "" : "s", input.line->baud,
               input.line->format());
}

}  // namespace

SourceInfo live_capture_header(const Decoding& decoding, const SourceInfo& live) {
    SourceInfo header;
    header.line = live.line;
    header.name = live.name;
    header.written_by = "rtuscope " RTUSCOPE_VERSION;
    if (decoding.options.bus == nullptr) return header;
    std::vector<const Profile*> embedded;
    for (unsigned address = 0; address < 256; ++address) {
        const Profile* own = decoding.options.bus->profile_for(static_cast<std::uint8_t>(address));
        // A header can only name profiles: a slave's --as registers are not in it, and a
        // profile of nothing but --as registers leaves its slave out.
        const Profile* p = own == nullptr ? nullptr : decoding.options.bus->find_profile(own->name);
        if (p == nullptr) continue;
        header.devices.emplace_back(static_cast<std::uint8_t>(address), p->name);
        if (p->file.starts_with("<bundled>") ||
            std::find(embedded.begin(), embedded.end(), p) != embedded.end()) {
            continue;
        }
        embedded.push_back(p);
        auto text = read_text_file(p->file);
        if (text) header.embedded_profiles.emplace_back(p->name, std::move(*text));
    }
    return header;
}

std::optional<Decoding> prepare_decoding(const OutputArgs& args, int& exit_code,
                                         const SourceInfo* input) {
    Decoding d;
    auto fail = [&](const Error& error, int code) {
        print_error(error);
        exit_code = code;
        return std::nullopt;
    };
    if (args.baud == "auto") {
        return fail(Error{"--baud auto listens to a live port (sniff, watch); to read a "
                          "capture's rate from its timing: rtuscope detect FILE"},
                    2);
    }
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

    std::vector<QuickType> quick_types;
    for (const std::string& text : args.quick_types) {
        auto q = parse_quick_type(text);
        if (!q) return fail(q.error(), 2);
        quick_types.push_back(std::move(*q));
    }
    auto bus = build_bus(args.bus);
    if (!bus) return fail(bus.error(), 1);
    if (Status s = assign_devices(**bus, args.bus); !s) return fail(s.error(), 2);
    d.bus = std::move(*bus);
    if (input != nullptr) {
        if (Status s = use_capture_header(*d.bus, *input, args); !s) return fail(s.error(), 1);
        note_line_replaced(*input, args);
    }
    if (args.bus.devices.empty() && args.bus.bus_file.empty()) assign_one_address_profiles(*d.bus);
    apply_quick_types(*d.bus, quick_types);
    if (!d.bus->empty()) d.options.bus = d.bus.get();
    d.options.guess = args.guess;
    if (args.values_csv && d.options.bus == nullptr && !args.guess) {
        return fail(Error{"--values-csv needs to know the devices: --device ADDR=PROFILE, "
                          "--bus FILE or --as SLAVE:ADDR=TYPE (or --guess)"},
                    2);
    }

    RecordFilter filter;
    if (!args.slaves.empty()) {
        auto r = parse_ranges(args.slaves, 255);
        if (!r) return fail(Error{"--slave: " + r.error().message}, 2);
        filter.slaves = *r;
    }
    if (!args.functions.empty()) {
        auto r = parse_ranges(args.functions, 127);
        if (!r) return fail(Error{"--function: " + r.error().message}, 2);
        filter.functions = *r;
    }
    if (!args.kinds.empty()) {
        auto r = parse_kinds(args.kinds);
        if (!r) return fail(Error{"--kind: " + r.error().message}, 2);
        filter.kinds = *r;
    }
    for (const auto& [text, bound, name] : {std::tuple(&args.from, &filter.from, "--from"),
                                            std::tuple(&args.to, &filter.to, "--to")}) {
        if (text->empty()) continue;
        auto r = parse_time_bound(*text);
        if (!r) return fail(Error{std::string(name) + ": " + r.error().message}, 2);
        *bound = *r;
    }
    d.from = filter.from;
    d.to = filter.to;
    d.filter = filter;

    // A file or a pipe takes the output in large blocks (a terminal keeps its lines); live
    // runs flush after every record anyway. 64 KiB, as the sinks' own blocks: a larger
    // buffer saves no more time (1 MiB: the same, and 0.9 MiB more RSS). glibc takes the
    // size only with a buffer to go with it (given none, it keeps its 4 KiB). The buffer
    // is static, with nothing to destroy: stdio flushes it after static destructors.
    if (!isatty(STDOUT_FILENO)) {
        static std::array<char, kIoBlockBytes> stdout_buffer;
        std::setvbuf(stdout, stdout_buffer.data(), _IOFBF, stdout_buffer.size());
    }

    if (args.stats) {
        d.sink = make_stats_sink(stdout, args.csv     ? StatsFormat::csv
                                         : args.jsonl ? StatsFormat::jsonl
                                                      : StatsFormat::text,
                                 args.stats_top);
    } else if (args.csv) {
        d.sink = make_csv_sink(stdout);
    } else if (args.jsonl) {
        d.sink = make_jsonl_sink(stdout);
    } else if (args.values_csv) {
        d.sink = make_values_csv_sink(stdout);
    } else {
        TextOptions text;
        text.hex = args.hex;
        text.values = !args.no_values;
        text.fit_terminal = isatty(STDOUT_FILENO) != 0;
        text.color = !args.no_color && std::getenv("NO_COLOR") == nullptr && isatty(STDOUT_FILENO);
        text.time_format = time_format(args.time_format);
        d.sink = make_text_sink(stdout, text);
    }
    std::vector<std::unique_ptr<RecordSink>> sinks;
    sinks.push_back(std::move(d.sink));
    if (args.closing_stats) sinks.push_back(make_stats_sink(stderr, StatsFormat::text));
    if (!args.pcap_file.empty()) {
        auto pcap = make_pcap_sink(args.pcap_file);
        if (!pcap) return fail(pcap.error(), 1);
        d.pcap = pcap->get();
        sinks.push_back(std::move(*pcap));
    }
    if (!args.pcapng_file.empty()) {
        auto pcapng = make_pcapng_sink(args.pcapng_file, "rtuscope " RTUSCOPE_VERSION);
        if (!pcapng) return fail(pcapng.error(), 1);
        d.pcapng = pcapng->get();
        sinks.push_back(std::move(*pcapng));
    }
    d.sink = sinks.size() == 1 ? std::move(sinks.front()) : make_tee_sink(std::move(sinks));
    if (!filter.empty()) d.sink = make_filter_sink(std::move(filter), std::move(d.sink));
    return d;
}

Status check_time_bounds(const Decoding& decoding, TimeBase base) {
    for (const auto& [bound, name] :
         {std::pair(&decoding.from, "--from"), std::pair(&decoding.to, "--to")}) {
        if (!*bound) continue;
        Status status = check_time_bound(**bound, base);
        if (!status) return Error{std::string(name) + ": " + status.error().message};
    }
    return ok_status();
}

Status pcap_status(const Decoding& decoding) {
    if (decoding.pcap != nullptr) {
        if (Status s = decoding.pcap->status(); !s) return s;
    }
    return decoding.pcapng != nullptr ? decoding.pcapng->status() : ok_status();
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
