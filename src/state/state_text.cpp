#include "state/state_text.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>

#include "profiles/profile.hpp"
#include "util/terminal.hpp"

namespace rtuscope {
namespace {

// "0.2 s", "12 s", "5 min", "3 h", "2 d"; "-" when unknown.
std::string age_text(Nanos now, Nanos then) {
    if (!has_time(now) || !has_time(then)) return "-";
    const double s = static_cast<double>(std::max<Nanos>(0, now - then)) / 1e9;
    if (s < 10) return fmt::format("{:.1f} s", s);
    if (s < 120) return fmt::format("{:.0f} s", s);
    if (s < 7200) return fmt::format("{:.0f} min", s / 60);
    if (s < 172800) return fmt::format("{:.0f} h", s / 3600);
    return fmt::format("{:.0f} d", s / 86400);
}

std::string ms_text(std::optional<Nanos> d) {
    return d ? fmt::format("{:.1f}", static_cast<double>(*d) / 1e6) : "-";
}

// Seconds of the window a rate is taken over: the last minute, or since the first sight.
double window_seconds(Nanos now, Nanos since) {
    if (!has_time(now) || !has_time(since)) return 0;
    const double seen = static_cast<double>(now - since) / 1e9;
    return std::clamp(seen, 1.0, static_cast<double>(PerSecond::kSeconds));
}

// Pads to `width` display columns (left-aligned), or cuts.
std::string cell(std::string text, std::size_t width) {
    cut_to_width(text, width);
    const std::size_t w = display_width(text);
    if (w < width) text.append(width - w, ' ');
    return text;
}

std::string right(const std::string& text, std::size_t width) {
    const std::size_t w = display_width(text);
    return w >= width ? text : std::string(width - w, ' ') + text;
}

// One line of the register table, its columns aligned whatever the text's width.
std::string register_line(const std::string& table, const std::string& address,
                          const std::string& name, const std::string& value,
                          const std::string& unit, const std::string& raw, const std::string& age,
                          const std::string& written, const std::string& changed,
                          const std::string& changes,
                          const std::string& min,
                          const std::string& max, const std::string& history) {
    std::string shown = value;
    cut_to_width(shown, 12);
    // Raw words last: the profile's value says the same, and a narrow screen cuts the right.
    std::string line = cell(table, 8) + ' ' + cell(address, 6) + ' ' + cell(name, 20) + ' ' +
                       right(shown, 12) + ' ' + cell(unit, 7) + ' ' + right(age, 6) + ' ' +
                       right(written, 7) + ' ' + right(changed, 7) + ' ' + right(changes, 4) + ' ' + right(min, 9) + ' ' + right(max, 9) + ' ' +
                       cell(history, ValueHistory::kSize) + ' ' + raw;
    while (!line.empty() && line.back() == ' ') line.pop_back();
    return line;
}

}  // namespace

std::string sparkline(const ValueHistory& history) {
    static constexpr std::array<const char*, 8> kBars = {"▁", "▂", "▃", "▄", "▅", "▆", "▇", "█"};
    if (history.size() == 0) return {};
    float lo = history.at(0);
    float hi = lo;
    for (std::size_t i = 1; i < history.size(); ++i) {
        lo = std::min(lo, history.at(i));
        hi = std::max(hi, history.at(i));
    }
    std::string out;
    for (std::size_t i = 0; i < history.size(); ++i) {
        const float v = history.at(i);
        const auto level = hi > lo ? static_cast<std::size_t>(std::lround((v - lo) / (hi - lo) * 7))
                                   : std::size_t{3};
        out += kBars[std::min<std::size_t>(level, 7)];
    }
    return out;
}

std::string bus_line(const BusState& state, const StateView& view) {
    const SessionInfo& session = state.session();
    std::string out = fmt::format("bus: {} {}", session.line.baud, session.line.format());
    const Nanos now = view.now;
    if (const auto rates = state.recent_rates(now)) {
        fmt::format_to(std::back_inserter(out), ", {:.1f} frames/s, utilisation {:.1f} %",
                       rates->frames_per_second, rates->utilisation * 100);
        const std::uint64_t errors = state.errors().within(now, PerSecond::kSeconds);
        fmt::format_to(std::back_inserter(out), ", {} {} in the last minute", errors,
                       errors == 1 ? "error" : "errors");
    } else {
        fmt::format_to(std::back_inserter(out), ", {} frames, no timing", state.stats().bus().frames);
    }
    if (has_time(state.last_time())) {
        fmt::format_to(std::back_inserter(out), ", last frame {} ago",
                       age_text(now, state.last_time()));
    }
    if (const auto dropped = state.messages_dropped()) {
        fmt::format_to(std::back_inserter(out), ", {} MQTT {} dropped", *dropped,
                       *dropped == 1 ? "message" : "messages");
    }
    return out;
}

std::vector<StyledLine> slave_table(const BusState& state, const StateView& view) {
    std::vector<StyledLine> lines;
    lines.push_back({"slave profile         polls/s answered p50 ms p95 ms  exc no ans  crc last seen",
                     LineStyle::heading});
    for (const SlaveState* s : state.slaves()) {
        const FunctionStats f = state.figures(s->address);
        const double seconds = window_seconds(view.now, s->first_seen);
        const std::string rate =
            seconds > 0 ? fmt::format("{:.1f}", static_cast<double>(s->requests.within(
                                                    view.now, static_cast<std::size_t>(
                                                                  std::ceil(seconds)))) /
                                                    seconds)
                        : "-";
        const std::uint64_t answered = f.requests - f.no_answer;
        const double share =
            f.requests == 0 ? 0 : static_cast<double>(answered) * 100 / static_cast<double>(f.requests);
        const std::string answered_text =
            f.requests == 0 ? "-" : fmt::format("{:.1f} %", share);
        std::string line = right(std::to_string(s->address), 5) + ' ' +
                           cell(s->profile != nullptr ? s->profile->name : "-", 15) + ' ' +
                           right(rate, 7) + ' ' + right(answered_text, 8) + ' ' +
                           right(ms_text(s->turnarounds.percentile(50)), 6) + ' ' +
                           right(ms_text(s->turnarounds.percentile(95)), 6) + ' ' +
                           right(std::to_string(f.exceptions), 4) + ' ' +
                           right(std::to_string(f.no_answer), 6) + ' ' +
                           right(std::to_string(f.crc_errors), 4) + ' ' +
                           age_text(view.now, s->last_seen);
        const LineStyle style = f.requests == 0                   ? LineStyle::plain
                                : share < 50                      ? LineStyle::failing
                                : share < 99.5 || f.exceptions > 0 ? LineStyle::degraded
                                                                  : LineStyle::healthy;
        lines.push_back({std::move(line), style});
    }
    return lines;
}

std::vector<const RegisterState*> shown_registers(const BusState& state, std::uint8_t slave,
                                                  const StateView& view) {
    std::vector<const RegisterState*> registers = state.registers(slave);
    if (!view.register_filter.empty()) {
        std::erase_if(registers, [&](const RegisterState* r) {
            return state.text(r->name).find(view.register_filter) == std::string_view::npos;
        });
    }
    if (view.sort == StateView::Sort::name) {
        std::stable_sort(registers.begin(), registers.end(),
                         [&](const RegisterState* a, const RegisterState* b) {
                             return state.text(a->name) < state.text(b->name);
                         });
    } else if (view.sort == StateView::Sort::last_change) {
        std::stable_sort(registers.begin(), registers.end(),
                         [](const RegisterState* a, const RegisterState* b) {
                             return a->last_change > b->last_change;
                         });
    }
    return registers;
}

std::vector<StyledLine> register_table(const BusState& state,
                                       std::span<const RegisterState* const> registers,
                                       const StateView& view) {
    std::vector<StyledLine> lines;
    lines.push_back({register_line("table", "addr", "name", "value", "unit", "raw", "age",
                                   "written", "changed", "n", "min", "max", "last values"),
                     LineStyle::heading});
    for (const RegisterState* r : registers) {
        std::string raw;
        for (std::size_t i = 0; i < std::min<std::size_t>(r->raw_words, r->raw.size()); ++i) {
            if (i > 0) raw += ' ';
            raw += fmt::format("0x{:04X}", r->raw[i]);
        }
        if (r->raw_words > r->raw.size()) raw += " …";
        // Written by the master: when (or "yes" without timing), "?" while its echo is
        // awaited or never came; the write's record number at the end of the line.
        const RegisterWrite* w = state.write(*r);
        std::string written;
        if (w != nullptr) {
            written = has_time(w->at) ? age_text(view.now, w->at) : "yes";
            if (!w->confirmed) written += '?';
        }
        std::string line = register_line(
            std::string(state.table_name(r->key.table)), fmt::format("0x{:04X}", r->key.address),
            std::string(state.text(r->name)), r->value, std::string(state.text(r->unit)), raw,
            age_text(view.now, r->last_update), written,
            r->changes > 0 ? age_text(view.now, r->last_change) : "", std::to_string(r->changes),
            r->numeric ? fmt::format("{:g}", r->min) : "",
            r->numeric ? fmt::format("{:g}", r->max) : "", sparkline(r->history));
        LineStyle style = LineStyle::plain;
        if (w != nullptr) {
            line += fmt::format("  write #{}{}", w->by, w->confirmed ? "" : ", no echo");
            style = LineStyle::written;
        }
        if (has_time(view.now) && has_time(r->last_change) && r->changes > 0 &&
            view.now - r->last_change < kNanosPerSecond) {
            style = LineStyle::changed;
        }
        lines.push_back({std::move(line), style});
    }
    return lines;
}

std::string state_text(const BusState& state, const StateView& view) {
    std::string out = bus_line(state, view) + '\n';
    for (const StyledLine& l : slave_table(state, view)) out += l.text + '\n';
    for (const SlaveState* s : state.slaves()) {
        const std::vector<StyledLine> registers =
            register_table(state, shown_registers(state, s->address, view), view);
        if (registers.size() <= 1) continue;
        out += fmt::format("\nslave {} ({}):\n", s->address,
                           s->profile != nullptr ? s->profile->name : "no profile");
        for (const StyledLine& l : registers) out += l.text + '\n';
    }
    if (const std::vector<std::string> anomalies = state.anomalies(); !anomalies.empty()) {
        out += "\nrecent anomalies:\n";
        for (const std::string& a : anomalies) out += "  " + a + '\n';
    }
    if (state.forgotten_registers() > 0) {
        out += fmt::format("({} registers forgotten, not updated for the longest, to keep {})\n",
                           state.forgotten_registers(), BusState::kMaxRegisters);
    }
    return out;
}

}  // namespace rtuscope
