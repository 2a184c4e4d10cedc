// The bus's state as text: the bus line, the table of slaves and a slave's registers.
// `watch` draws these lines on its screen, `watch --plain` prints them, and a frozen
// snapshot (`f`) saves them; one renderer, so the three never differ.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "state/bus_state.hpp"

namespace rtuscope {

// How a line wants to be shown, where colour is available.
enum class LineStyle : std::uint8_t {
    plain,
    heading,
    healthy,  // a slave that answers (nearly) everything
    degraded, // a slave missing some answers, or answering exceptions
    failing,  // a slave answering little or nothing
    changed,  // a register whose value changed within the last second
    written,  // a register the master wrote
};

struct StyledLine {
    std::string text;
    LineStyle style = LineStyle::plain;
};

// `now`: the time the ages are measured to, on the records' clock (a replay's is its
// capture's; a live run's the wall clock).
struct StateView {
    Nanos now = kNoTime;
    std::string register_filter;  // registers whose name contains it; "" for all
    enum class Sort : std::uint8_t { address, name, last_change } sort = Sort::address;
};

// "bus: 9600 8N1, 12.0 frames/s, utilisation 23.4 %, 0 errors in the last minute, last
// frame 0.2 s ago"
std::string bus_line(const BusState& state, const StateView& view);
// The heading and one line per slave, by address.
std::vector<StyledLine> slave_table(const BusState& state, const StateView& view);
// The registers of `slave` that the view's filter keeps, in its order.
std::vector<const RegisterState*> shown_registers(const BusState& state, std::uint8_t slave,
                                                  const StateView& view);
// The heading and one line per register (a screen shows the ones that fit).
std::vector<StyledLine> register_table(const BusState& state,
                                       std::span<const RegisterState* const> registers,
                                       const StateView& view);
// Everything, every slave's registers included: the plain output and a snapshot.
std::string state_text(const BusState& state, const StateView& view);

// "▁▃▅█": the values scaled between their minimum and maximum.
std::string sparkline(const ValueHistory& history);

}  // namespace rtuscope
