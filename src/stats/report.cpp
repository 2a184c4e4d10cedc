// The statistics printed as text, CSV or JSON lines (docs/formats.md), row by row.
#include "stats/report.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <functional>
#include <iterator>
#include <string_view>

#include "decode/decoder.hpp"
#include "output/block_output.hpp"
#include "output/fields.hpp"
#include "output/sinks.hpp"
#include "util/io_block.hpp"
#include "util/text.hpp"

namespace rtuscope {
namespace {

// One row of figures, whatever the output format; nullopt where not known.
struct RowFigures {
    std::optional<BusStats::Key> key;  // nullopt: every slave and function
    const FunctionStats* counts = nullptr;
    std::optional<Nanos> p50, p95, p99, max;
    std::optional<Nanos> cycle_median, cycle_max;
    const DurationCounts* cycles = nullptr;  // of the row's poll, if it has one
};

// The row of one slave and function, or the bus-wide row (`key` nullopt, `s` the sums),
// whose cycle is that of the bus's most frequent poll, as in the bus block.
RowFigures row_of(const BusStats& stats, std::optional<BusStats::Key> key, const FunctionStats& s) {
    RowFigures f{key, &s, {}, {}, {}, {}, {}, {}, nullptr};
    f.p50 = s.turnarounds.percentile(50);
    f.p95 = s.turnarounds.percentile(95);
    f.p99 = s.turnarounds.percentile(99);
    f.max = s.turnarounds.percentile(100);
    if (const auto* poll = stats.main_poll(key); poll != nullptr) {
        f.cycle_median = poll->second.cycles.percentile(50);
        f.cycle_max = poll->second.cycles.percentile(100);
        f.cycles = &poll->second.cycles;
    }
    return f;
}

RowFigures bus_row(const BusStats& stats) {
    return row_of(stats, std::nullopt, stats.all());
}

// Every slave and function's row, then the bus-wide one, each made as it is printed:
// noise in a long capture can fill the table (256 x 128 rows), too many to hold at once.
template <class Each>
void for_each_row(const BusStats& stats, Each each) {
    for (const auto& [key, s] : stats.functions()) each(row_of(stats, key, s));
    each(bus_row(stats));
}

// The statistics' text, handed to `send` in pieces of about 64 KiB at line ends rather
// than held whole: a full table is megabytes of text, and a run's peak RSS stays below
// 32 MiB whatever the capture.
class Pieces {
  public:
    explicit Pieces(const std::function<void(std::string_view)>& send) : send_(send) {}
    Pieces(const Pieces&) = delete;
    Pieces& operator=(const Pieces&) = delete;

    std::string& text() { return text_; }
    void line_done() {
        if (text_.size() >= kIoBlockBytes) send();
    }
    void send() {
        if (text_.empty()) return;
        send_(text_);
        text_.clear();
    }

  private:
    const std::function<void(std::string_view)>& send_;
    std::string text_;
};

std::string ms(std::optional<Nanos> t, int decimals, std::string_view unknown) {
    if (!t) return std::string(unknown);
    return fmt::format("{:.{}f}", static_cast<double>(*t) / 1e6, decimals);
}

// A percentile in the text output: "~" marks one counted in bins, up to a bin below the
// exact figure (DurationCounts).
std::string ms_text(std::optional<Nanos> t, Nanos bin) {
    std::string out = ms(t, 2, "-");
    return t && bin != 0 ? "~" + out : out;
}

// The CSV's and JSONL's bin width of percentiles (DurationCounts): 0 when exact,
// `unknown` when there are no values.
std::string bin_ms(const DurationCounts* values, std::string_view unknown) {
    if (values == nullptr || values->empty()) return std::string(unknown);
    return ms(values->bin_width(), 3, unknown);
}

// The entry a row's frames were decoded by: the device's own where its profile has one.
const FunctionSpec& function_of(const BusStats& stats, std::uint8_t slave, std::uint8_t code) {
    const auto row = stats.functions().find({slave, code});
    if (row != stats.functions().end() && row->second.function != nullptr) {
        return *row->second.function;
    }
    return standard_function(code);
}

// "0x0000 x2" for the reads of a table (01-04), whose first 4 data bytes are address and
// quantity; the bytes in hex for anything else (a device's own function too).
std::string poll_data_text(const BusStats& stats, const PollKey& key) {
    const FunctionSpec& spec = function_of(stats, key.slave, key.function);
    if (spec.access == DataAccess::read && spec.table != DataTable::none && key.size == 4) {
        return fmt::format("0x{:02X}{:02X} x{}", key.data[0], key.data[1],
                           key.data[2] * 256U + key.data[3]);
    }
    std::string text;
    append_hex(text, std::span(key.data.data(), key.size), true);
    return text;
}

// Columns padded to their widest cell; `right` marks the numeric ones. `rows(emit)` emits
// the rows, header first; it runs twice (the widths, then the lines), so that no table is
// held whole.
template <class Rows>
void table(Pieces& out, const std::vector<bool>& right, Rows rows) {
    std::vector<std::size_t> widths(right.size(), 0);
    rows([&](const std::vector<std::string>& row) {
        for (std::size_t i = 0; i < row.size(); ++i) widths[i] = std::max(widths[i], row[i].size());
    });
    rows([&](const std::vector<std::string>& row) {
        std::string& line = out.text();
        const std::size_t start = line.size();
        line += "  ";
        for (std::size_t i = 0; i < row.size(); ++i) {
            if (i > 0) line += "  ";
            line += right[i] ? fmt::format("{:>{}}", row[i], widths[i])
                             : fmt::format("{:<{}}", row[i], widths[i]);
        }
        while (line.size() > start && line.back() == ' ') line.pop_back();
        line += '\n';
        out.line_done();
    });
}

// Whether a poll's repeats keep a rhythm: its p95 at most twice its median. Irregular
// repeats (a write now and then, a request the operator sends by hand) have no cycle.
bool regular(const DurationCounts& cycles) {
    const auto median = cycles.percentile(50);
    const auto p95 = cycles.percentile(95);
    return median && p95 && *p95 <= 2 * *median;
}

// A row that is bus traffic: something was asked or answered. Rows of frames that are
// neither (a corrupt address or function code: CRC errors only) are not.
bool is_traffic(const FunctionStats& s) {
    return s.requests + s.answers + s.exceptions + s.broken + s.broadcasts + s.unsolicited != 0;
}

std::uint64_t frames_of(const FunctionStats& s) {
    return s.requests + s.answers + s.exceptions + s.broken + s.broadcasts + s.unsolicited +
           s.crc_errors;
}

// The `top` busiest of `items` by `weight` (all of them for top 0), in their own order.
template <class T, class Weight>
std::vector<T> busiest(std::vector<T> items, std::size_t top, Weight weight) {
    if (top == 0 || items.size() <= top) return items;
    std::vector<T> by_weight = items;
    std::stable_sort(by_weight.begin(), by_weight.end(),
                     [&](const T& a, const T& b) { return weight(a) > weight(b); });
    by_weight.resize(top);
    std::vector<T> kept;
    for (const T& item : items) {
        if (std::find(by_weight.begin(), by_weight.end(), item) != by_weight.end()) {
            kept.push_back(item);
        }
    }
    return kept;
}

std::string_view to_string(BaudOrigin origin) {
    switch (origin) {
        case BaudOrigin::input:
            return "input";
        case BaudOrigin::option:
            return "option";
        case BaudOrigin::profiles:
            return "profiles";
        case BaudOrigin::assumed:
            break;
    }
    return "assumed";
}

// The utilisation is bytes × character time over the duration: a fact only as far as the
// baud rate is. One the input does not give is said to be taken from the profiles or
// assumed; and a figure over 100 % is no utilisation but a wrong baud rate.
std::string utilisation_text(const BusStats& stats) {
    const SessionInfo& session = stats.session();
    const std::uint64_t tcp_bytes = stats.bus().tcp_bytes;
    if (!stats.utilisation()) return "Modbus/TCP alone: no serial line to measure";
    const std::uint64_t bytes = stats.bus().bytes - tcp_bytes;
    const double percent = *stats.utilisation();
    const std::uint32_t baud = session.line.baud;
    if (!stats.utilisation_possible()) {
        return fmt::format(
            "utilisation impossible: {} {} at {} baud take {:.3f} s, more than the input lasts; "
            "the baud rate is wrong ({}; at least {} baud fits)",
            bytes, plural(bytes, "byte", "bytes"), baud,
            static_cast<double>(*stats.duration()) / 1e9 * percent / 100,
            session.baud_origin == BaudOrigin::option    ? "--baud gives it"
            : session.baud_origin == BaudOrigin::input   ? "the input's header gives it"
            : session.baud_origin == BaudOrigin::profiles ? "the profiles give it"
                                                          : "it is assumed: --baud gives it",
            standard_baud_at_least(baud * percent / 100));
    }
    std::string origin;
    if (session.baud_origin == BaudOrigin::profiles) {
        origin = fmt::format(", at the {} baud the profiles give", baud);
    } else if (session.baud_origin == BaudOrigin::assumed) {
        origin = fmt::format(", at an assumed {} baud", baud);
    }
    if (tcp_bytes > 0) {
        origin += fmt::format("; {} {} of Modbus/TCP left out", tcp_bytes,
                              plural(tcp_bytes, "byte", "bytes"));
    }
    return fmt::format("utilisation {:.1f} % ({} {} of {:.3f} ms{})", percent, bytes,
                       plural(bytes, "byte", "bytes"),
                       static_cast<double>(session.line.char_time()) / 1e6, origin);
}

// What the text lists: the busiest rows that are bus traffic, the busiest polls that
// keep a rhythm; the rest is counted.
struct TextSelection {
    using Row = const std::pair<const BusStats::Key, FunctionStats>*;
    using Poll = const std::pair<const PollKey, PollStats>*;
    std::vector<Row> traffic;  // rows where something was asked or answered
    std::vector<Row> shown;
    std::uint64_t junk_rows = 0;  // rows of garbled invalid frames only
    std::uint64_t junk_crc_errors = 0;
    std::vector<Poll> cyclic;  // polls whose repeats keep a rhythm
    std::vector<Poll> listed;
    std::uint64_t irregular = 0;
};

TextSelection select_for_text(const BusStats& stats, std::size_t top) {
    TextSelection sel;
    for (const auto& row : stats.functions()) {
        if (is_traffic(row.second)) {
            sel.traffic.push_back(&row);
        } else if (row.second.crc_errors != 0) {
            ++sel.junk_rows;
            sel.junk_crc_errors += row.second.crc_errors;
        }  // else nothing to count: a request the run stopped before its answer could come
    }
    sel.shown = busiest(sel.traffic, top, [](TextSelection::Row r) { return frames_of(r->second); });
    if (!stats.timed()) return sel;
    for (const auto& poll : stats.polls()) {
        if (poll.second.cycles.empty()) continue;
        if (regular(poll.second.cycles)) {
            sel.cyclic.push_back(&poll);
        } else {
            ++sel.irregular;
        }
    }
    sel.listed =
        busiest(sel.cyclic, top, [](TextSelection::Poll p) { return p->second.requests; });
    return sel;
}

// How far below the exact figure a binned percentile the text shows can be: the widest
// bin, and the largest share of its figure a bin takes (0, 0: all exact).
struct BinBound {
    Nanos widest = 0;
    double share = 0;
    void add(const DurationCounts& counts, std::initializer_list<unsigned> percents) {
        if (counts.bin_width() == 0) return;
        widest = std::max(widest, counts.bin_width());
        for (unsigned percent : percents) {
            const auto figure = counts.percentile(percent);
            if (figure && *figure > 0) {
                share = std::max(share, static_cast<double>(counts.bin_width()) /
                                            static_cast<double>(*figure));
            }
        }
    }
};

BinBound bin_bound(const BusStats& stats, const TextSelection& sel) {
    BinBound bound;
    const auto add_row = [&](std::optional<BusStats::Key> key, const FunctionStats& s) {
        bound.add(s.turnarounds, {50, 95, 99});
        if (const auto* poll = stats.main_poll(key); poll != nullptr && regular(poll->second.cycles)) {
            bound.add(poll->second.cycles, {50});
        }
    };
    for (TextSelection::Row row : sel.shown) add_row(row->first, row->second);
    add_row(std::nullopt, stats.all());
    for (TextSelection::Poll poll : sel.listed) bound.add(poll->second.cycles, {50});
    return bound;
}

void write_text(const BusStats& stats, const std::vector<std::string>& remarks, Pieces& pieces,
                std::size_t top) {
    const SessionInfo& session = stats.session();
    const BusFigures& bus = stats.bus();
    std::string& out = pieces.text();
    if (!session.source.name.empty()) {
        out += fmt::format("{}: {} input, {} {}\n", session.source.name, session.source.format,
                           session.line.baud, session.line.format());
    }
    if (!session.devices.empty()) out += fmt::format("devices: {}\n", session.devices);
    out += fmt::format("bus: {} {}, {} {}; {} invalid, {} unknown; {} {} in {} {}\n", bus.frames,
                       plural(bus.frames, "frame", "frames"), bus.bytes,
                       plural(bus.bytes, "byte", "bytes"), bus.invalid, bus.unknown,
                       bus.noise_bytes, plural(bus.noise_bytes, "noise byte", "noise bytes"),
                       bus.noise_runs, plural(bus.noise_runs, "run", "runs"));
    if (stats.timed()) {
        out += fmt::format("duration: {:.3f} s, {}\n",
                           static_cast<double>(*stats.duration()) / 1e9, utilisation_text(stats));
        const auto* poll = stats.main_poll(std::nullopt);
        if (poll != nullptr && !poll->second.cycles.empty() && !regular(poll->second.cycles)) {
            out += fmt::format(
                "poll cycle: none regular (the most frequent request, slave {} function {:02X} "
                "{}, repeats irregularly)\n",
                poll->first.slave, poll->first.function, poll_data_text(stats, poll->first));
        } else if (poll != nullptr && !poll->second.cycles.empty()) {
            out += fmt::format(
                "poll cycle: {} ms median, {} ms max (slave {} function {:02X} {}, "
                "{} {})\n",
                ms_text(poll->second.cycles.percentile(50), poll->second.cycles.bin_width()),
                ms(poll->second.cycles.percentile(100), 2, "-"), poll->first.slave,
                poll->first.function, poll_data_text(stats, poll->first), poll->second.requests,
                plural(poll->second.requests, "request", "requests"));
        } else {
            out += "poll cycle: no request repeated\n";
        }
    } else {
        out += "no timing: turnaround, utilisation and cycle unknown\n";
    }
    for (const std::string& remark : remarks) out += fmt::format("note: {}\n", remark);
    const TextSelection sel = select_for_text(stats, top);
    if (const BinBound bound = bin_bound(stats, sel); bound.widest != 0) {
        out += fmt::format(
            "note: ~ marks a percentile counted in bins (more than {} distinct turnarounds in "
            "a row or cycles of a poll): up to one bin below the exact figure, here at most "
            "{} ms and {:.1f} % of it\n",
            stats.bins_each(), ms(bound.widest, 3, ""), 100 * bound.share);
    }
    if (stats.unlisted_exceptions() != 0) {
        out += fmt::format(
            "note: {} exceptions not listed by code, beyond {} distinct slave/function/code "
            "(they still count in the rows)\n",
            stats.unlisted_exceptions(), BusStats::kMaxExceptionCodes);
    }
    if (stats.forgotten_polls() != 0) {
        out += fmt::format(
            "note: {} rare polls forgotten to keep to {} distinct requests (their requests "
            "still count in the rows)\n",
            stats.forgotten_polls(), BusStats::kMaxPolls);
    }

    // Short headers keep the table within a terminal's width for typical buses; the
    // legend says what they mean.
    out +=
        "\nper slave and function (times in ms; each request has one outcome: req = ans + "
        "exc + broken\n(an answer with a bad CRC or cut short) + no ans; p50..max: turnaround "
        "over the n measured\nanswers; cycle: of the slave's most frequent poll for that "
        "function):\n";
    using Row = TextSelection::Row;
    const std::vector<Row>& traffic = sel.traffic;
    const std::vector<Row>& shown = sel.shown;
    const auto row_cells = [&](const RowFigures& f) {
        const FunctionStats& c = *f.counts;
        const bool irregular = f.cycles != nullptr && !f.cycles->empty() && !regular(*f.cycles);
        return std::vector<std::string>{
            f.key ? fmt::format("{}", f.key->first) : "all",
            f.key ? fmt::format("{:02X}", f.key->second) : "",
            f.key ? function_of(stats, f.key->first, f.key->second).name : "",
            fmt::format("{}", c.requests), fmt::format("{}", c.answers),
            fmt::format("{}", c.exceptions), fmt::format("{}", c.broken),
            fmt::format("{}", c.no_answer), fmt::format("{}", c.crc_errors),
            fmt::format("{}", c.broadcasts), fmt::format("{}", c.unsolicited),
            fmt::format("{}", c.turnarounds.size()), ms_text(f.p50, c.turnarounds.bin_width()),
            ms_text(f.p95, c.turnarounds.bin_width()), ms_text(f.p99, c.turnarounds.bin_width()),
            ms(f.max, 2, "-"),
            irregular ? std::string("irregular")
                      : ms_text(f.cycle_median, f.cycles != nullptr ? f.cycles->bin_width() : 0),
            irregular ? std::string("-") : ms(f.cycle_max, 2, "-")};
    };
    const auto rows = [&](const auto& emit) {
        emit({"slave", "fc", "function", "req", "ans", "exc", "broken", "no ans", "crc", "bcast",
              "unsol", "n", "p50", "p95", "p99", "max", "cycle", "cyc max"});
        for (Row row : shown) emit(row_cells(row_of(stats, row->first, row->second)));
        emit(row_cells(bus_row(stats)));
    };
    table(pieces,
          {true, true, false, true, true, true, true, true, true, true, true, true, true, true,
           true, true, true, true},
          rows);
    if (shown.size() < traffic.size()) {
        std::uint64_t frames = 0;
        for (Row row : traffic) {
            if (std::find(shown.begin(), shown.end(), row) == shown.end()) {
                frames += frames_of(row->second);
            }
        }
        out += fmt::format("  ... {} more {} with {} {} (--top 0 lists them)\n",
                           traffic.size() - shown.size(),
                           plural(traffic.size() - shown.size(), "row", "rows"), frames,
                           plural(frames, "frame", "frames"));
    }
    if (sel.junk_rows != 0) {
        out += fmt::format(
            "  invalid frames that are no bus traffic (their address or function code "
            "garbled): {} {} under {} {}, in the all row\n",
            sel.junk_crc_errors, plural(sel.junk_crc_errors, "CRC error", "CRC errors"),
            sel.junk_rows, plural(sel.junk_rows, "slave and function", "slaves and functions"));
    }
    pieces.line_done();

    struct ExceptionRow {
        BusStats::Key key;
        std::uint8_t code;
        std::uint64_t count;
        bool operator==(const ExceptionRow&) const = default;
    };
    std::vector<ExceptionRow> exception_rows;
    for (const auto& [key, row] : stats.functions()) {
        for (const auto& [code, n] : row.exception_codes) exception_rows.push_back({key, code, n});
    }
    if (!exception_rows.empty()) {
        const std::vector<ExceptionRow> listed =
            busiest(exception_rows, top, [](const ExceptionRow& e) { return e.count; });
        const auto exceptions = [&](const auto& emit) {
            emit({"slave", "fc", "code", "exception", "count"});
            for (const ExceptionRow& e : listed) {
                const char* name = exception_name(e.code);
                emit({fmt::format("{}", e.key.first), fmt::format("{:02X}", e.key.second),
                      fmt::format("{:02X}", e.code), name != nullptr ? name : "undefined",
                      fmt::format("{}", e.count)});
            }
        };
        out += "\nexceptions:\n";
        table(pieces, {true, true, true, false, true}, exceptions);
        if (listed.size() < exception_rows.size()) {
            out += fmt::format("  ... {} more (--top 0 lists them)\n",
                               exception_rows.size() - listed.size());
        }
    }

    // Polls whose repeats keep a rhythm, the busiest first: a bus with varying writes or
    // requests sent by hand would otherwise list every one of them.
    if (sel.cyclic.empty() && sel.irregular == 0) return;
    using Poll = TextSelection::Poll;
    const std::vector<Poll>& listed = sel.listed;
    out += "\npolls (times in ms):\n";
    if (!listed.empty()) {
        const auto polls = [&](const auto& emit) {
            emit({"slave", "fc", "data", "requests", "cycle median", "cycle max"});
            for (Poll poll : listed) {
                const auto& [key, p] = *poll;
                emit({fmt::format("{}", key.slave), fmt::format("{:02X}", key.function),
                      poll_data_text(stats, key), fmt::format("{}", p.requests),
                      ms_text(p.cycles.percentile(50), p.cycles.bin_width()),
                      ms(p.cycles.percentile(100), 2, "-")});
            }
        };
        table(pieces, {true, true, false, true, true, true}, polls);
    }
    if (listed.size() < sel.cyclic.size()) {
        out += fmt::format("  ... {} more (--top 0 lists them)\n",
                           sel.cyclic.size() - listed.size());
    }
    if (sel.irregular != 0) {
        out += fmt::format(
            "  {} {} irregularly (p95 of the intervals above twice the median): no cycle\n",
            sel.irregular, plural(sel.irregular, "request repeats", "requests repeat"));
    }
}

void write_csv(const BusStats& stats, Pieces& pieces) {
    std::string& out = pieces.text();
    out +=
        "slave,function,requests,answers,exceptions,crc_errors,no_answer,broadcasts,"
        "unsolicited,turnarounds,turnaround_p50_ms,turnaround_p95_ms,turnaround_p99_ms,"
        "turnaround_max_ms,cycle_median_ms,cycle_max_ms,turnaround_bin_ms,cycle_bin_ms,broken\n";
    for_each_row(stats, [&](const RowFigures& f) {
        const FunctionStats& c = *f.counts;
        const std::string slave = f.key ? fmt::format("{}", f.key->first) : "all";
        const std::string function = f.key ? fmt::format("{}", f.key->second) : "all";
        // Columns are only ever added, at the end.
        out += fmt::format("{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n", slave,
                           function, c.requests, c.answers, c.exceptions, c.crc_errors, c.no_answer,
                           c.broadcasts, c.unsolicited, c.turnarounds.size(), ms(f.p50, 3, ""),
                           ms(f.p95, 3, ""), ms(f.p99, 3, ""), ms(f.max, 3, ""),
                           ms(f.cycle_median, 3, ""), ms(f.cycle_max, 3, ""),
                           bin_ms(&c.turnarounds, ""), bin_ms(f.cycles, ""), c.broken);
        pieces.line_done();
    });
}

// The members of a row's JSON object, without the braces.
void append_json_row(std::string& out, const RowFigures& f) {
    const FunctionStats& c = *f.counts;
    if (f.key) {
        fmt::format_to(std::back_inserter(out), "\"slave\":{},\"function\":{},", f.key->first,
                       f.key->second);
    }
    fmt::format_to(std::back_inserter(out),
                   "\"requests\":{},\"answers\":{},\"exceptions\":{},\"broken\":{},"
                   "\"exception_codes\":{{",
                   c.requests, c.answers, c.exceptions, c.broken);
    bool first = true;
    for (const auto& [code, n] : c.exception_codes) {
        fmt::format_to(std::back_inserter(out), "{}\"{}\":{}", first ? "" : ",", code, n);
        first = false;
    }
    fmt::format_to(std::back_inserter(out),
                   "}},\"crc_errors\":{},\"no_answer\":{},\"broadcasts\":{},\"unsolicited\":{},"
                   "\"turnarounds\":{},\"turnaround_p50_ms\":{},\"turnaround_p95_ms\":{},"
                   "\"turnaround_p99_ms\":{},\"turnaround_max_ms\":{},\"cycle_median_ms\":{},"
                   "\"cycle_max_ms\":{},\"turnaround_bin_ms\":{},\"cycle_bin_ms\":{}",
                   c.crc_errors, c.no_answer, c.broadcasts, c.unsolicited, c.turnarounds.size(),
                   ms(f.p50, 3, "null"), ms(f.p95, 3, "null"), ms(f.p99, 3, "null"),
                   ms(f.max, 3, "null"), ms(f.cycle_median, 3, "null"), ms(f.cycle_max, 3, "null"),
                   bin_ms(&c.turnarounds, "null"), bin_ms(f.cycles, "null"));
}

// A JSON object's `"key":"value"` member with the value as a JSON string.
void append_json_member(std::string& out, std::string_view key, std::string_view value) {
    out += '"';
    out += key;
    out += "\":";
    append_json_string(out, value);
}

void write_jsonl(const BusStats& stats, Pieces& pieces) {
    const SessionInfo& session = stats.session();
    const BusFigures& bus = stats.bus();
    std::string& out = pieces.text();
    out += "{\"bus\":{";
    append_json_member(out, "source", session.source.name);
    out += ',';
    append_json_member(out, "input_format", session.source.format);
    out += ',';
    append_json_member(out, "line", fmt::format("{} {}", session.line.baud, session.line.format()));
    out += ',';
    append_json_member(out, "devices", session.devices);
    out += ',';
    append_json_member(out, "baud_origin", to_string(session.baud_origin));
    const std::optional<double> utilisation =
        stats.utilisation_possible() ? stats.utilisation() : std::nullopt;
    fmt::format_to(std::back_inserter(out),
                   ",\"timed\":{},\"duration_s\":{},\"frames\":{},\"bytes\":{},\"noise_runs\":{},"
                   "\"noise_bytes\":{},\"invalid\":{},\"unknown\":{},\"char_time_ms\":{:.6f},"
                   "\"utilisation_pct\":{},\"poll\":",
                   stats.timed() ? "true" : "false",
                   stats.duration()
                       ? fmt::format("{:.6f}", static_cast<double>(*stats.duration()) / 1e9)
                       : "null",
                   bus.frames, bus.bytes, bus.noise_runs, bus.noise_bytes, bus.invalid, bus.unknown,
                   static_cast<double>(session.line.char_time()) / 1e6,
                   utilisation ? fmt::format("{:.3f}", *utilisation) : "null");
    if (const auto* p = stats.main_poll(std::nullopt); p != nullptr) {
        fmt::format_to(std::back_inserter(out), "{{\"slave\":{},\"function\":{},\"data\":\"",
                       p->first.slave, p->first.function);
        append_hex(out, std::span(p->first.data.data(), p->first.size), false);
        fmt::format_to(std::back_inserter(out),
                       "\",\"requests\":{},\"cycle_median_ms\":{},\"cycle_max_ms\":{},"
                       "\"cycle_bin_ms\":{}}}",
                       p->second.requests, ms(p->second.cycles.percentile(50), 3, "null"),
                       ms(p->second.cycles.percentile(100), 3, "null"),
                       bin_ms(&p->second.cycles, "null"));
    } else {
        out += "null";
    }
    fmt::format_to(std::back_inserter(out),
                   ",\"forgotten_polls\":{},\"unlisted_exceptions\":{},\"all\":{{",
                   stats.forgotten_polls(), stats.unlisted_exceptions());
    append_json_row(out, bus_row(stats));
    out += "}}}\n";
    for (const auto& [key, s] : stats.functions()) {
        out += '{';
        append_json_row(out, row_of(stats, key, s));
        out += "}\n";
        pieces.line_done();
    }
}

class StatsSink final : public RecordSink {
  public:
    StatsSink(std::FILE* out, StatsFormat format, std::size_t top)
        : out_(out), format_(format), top_(top) {}

    void begin(const SessionInfo& session) override { stats_.begin(session); }
    void record(const Record& record) override { stats_.add(record); }
    void end(const Totals& /*totals*/, const std::vector<std::string>& remarks) override {
        stats_.finish();
        write_stats(
            stats_, format_, remarks, [this](std::string_view text) { write_output(out_, text); },
            top_);
        flush_output(out_);
    }

  private:
    std::FILE* out_;
    StatsFormat format_;
    std::size_t top_;
    BusStats stats_;
};

}  // namespace

void write_stats(const BusStats& stats, StatsFormat format, const std::vector<std::string>& remarks,
                 const std::function<void(std::string_view)>& send, std::size_t top) {
    Pieces pieces(send);
    switch (format) {
        case StatsFormat::csv:
            write_csv(stats, pieces);
            break;
        case StatsFormat::jsonl:
            write_jsonl(stats, pieces);
            break;
        case StatsFormat::text:
            write_text(stats, remarks, pieces, top);
            break;
    }
    pieces.send();
}

std::string render_stats(const BusStats& stats, StatsFormat format,
                         const std::vector<std::string>& remarks, std::size_t top) {
    std::string text;
    write_stats(stats, format, remarks, [&](std::string_view piece) { text += piece; }, top);
    return text;
}

std::unique_ptr<RecordSink> make_stats_sink(std::FILE* out, StatsFormat format, std::size_t top) {
    return std::make_unique<StatsSink>(out, format, top);
}

}  // namespace rtuscope
