// The CRC end index's table and its indexing; see crc_end_index.hpp for the idea.
#include "framing/crc_end_index.hpp"

#include <algorithm>
#include <array>

#include "framing/crc.hpp"

namespace rtuscope {
namespace {

constexpr std::uint32_t kCycle = 32767;   // the length of both cycles
constexpr std::uint16_t kFixed = 0x7FFF;  // place of a fixed point (no cycle place is)

using Places = std::array<std::uint16_t, 65536>;

// Walks both cycles once, at compile time: 128 KiB of read-only data, paged in only by
// inputs with lengths to search (a table made at run time costs a decode ~1 M
// instructions and its page faults as soon as one search is indexed).
constexpr Places make_places() {
    // kCrcTables is not a constant in this file: its byte table made again.
    constexpr auto byte_table = detail::make_crc_byte_table();
    Places places{};
    places[0] = kFixed;
    places[0xC001] = 0x8000U | kFixed;
    // 1 and 3 lie on different cycles (the unit test checks that each walk closes after
    // kCycle steps and that together they cover every other value).
    const std::uint16_t starts[2] = {1, 3};
    for (std::uint16_t cycle = 0; cycle < 2; ++cycle) {
        std::uint16_t reg = starts[cycle];
        for (std::uint32_t place = 0; place < kCycle; ++place) {
            places[reg] = static_cast<std::uint16_t>((cycle << 15U) | place);
            reg = static_cast<std::uint16_t>((reg >> 8U) ^ byte_table[reg & 0xFFU]);  // a zero byte
        }
    }
    return places;
}

constinit const Places kPlaces = make_places();

// `place` (a register's) moved back by `shift` (< kCycle) places along its cycle; a fixed
// point stays.
std::uint16_t shifted(std::uint16_t place, std::uint32_t shift) {
    const std::uint32_t on_cycle = place & kFixed;
    if (on_cycle == kFixed) return place;
    const std::uint32_t back = on_cycle >= shift ? on_cycle - shift : on_cycle + kCycle - shift;
    return static_cast<std::uint16_t>((place & 0x8000U) | back);
}

}  // namespace

std::uint16_t crc_cycle_place(std::uint16_t reg) {
    return kPlaces[reg];
}

bool CrcEndIndex::may_hold(Window& window, std::span<const std::uint8_t> bytes,
                           std::uint16_t target, std::size_t from, std::size_t to) {
    if (to - from > kMaxWindow) return true;
    if (window.counts.empty()) window.counts.resize(65536);
    // Searches through garbage follow each other a byte apart: indexed a block ahead,
    // not a byte or two a call.
    if (to - 1 - from_ >= keys_.size()) {
        index_to(bytes, std::min(bytes.size(), to - 1 + kMaxWindow));
    }
    if (from < window.from || from > window.to) {
        empty(window);
        window.from = window.to = from;
    }
    // Slid forward to start at `from` and to reach `to` at least: it then covers no more
    // than the longer of this search and the last one (kMaxWindow at most).
    for (; window.from < from; ++window.from) --window.counts[keys_[window.from - from_]];
    for (; window.to < to; ++window.to) ++window.counts[keys_[window.to - from_]];
    return window.counts[target] != 0;
}

void CrcEndIndex::empty(Window& window) {
    for (std::size_t k = window.from; k < window.to; ++k) --window.counts[keys_[k - from_]];
    window.from = window.to = 0;
}

void CrcEndIndex::empty_windows() {
    for (Window& window : windows_) empty(window);
}

void CrcEndIndex::start_at(std::size_t at) {
    empty_windows();
    from_ = at;
    zero_runs_.assign(1, 0);
    keys_.assign(1, kFixed);  // Z = 0, a fixed point
}

void CrcEndIndex::index_to(std::span<const std::uint8_t> bytes, std::size_t to) {
    const std::size_t have = keys_.size();
    const std::size_t want = to + 1 - from_;
    if (want <= have) return;
    zero_runs_.resize(want);
    keys_.resize(want);
    std::uint16_t reg = zero_runs_[have - 1];
    std::size_t i = have;
    auto shift = static_cast<std::uint32_t>(i % kCycle);  // i's, counted up with i
    auto add = [&](std::uint16_t run) {
        zero_runs_[i] = run;
        keys_[i] = shifted(kPlaces[run], shift);
        ++i;
        if (++shift == kCycle) shift = 0;
    };
    // Four bytes a step, as in find_directly: each step waits only for the one before.
    while (i + 4 <= want) {
        const auto runs = crc16_modbus_each_of_4(reg, &bytes[from_ + i - 1]);
        for (const std::uint16_t run : runs) add(run);
        reg = runs[3];
    }
    while (i < want) {
        reg = crc16_modbus_byte(reg, bytes[from_ + i - 1]);
        add(reg);
    }
}

std::uint16_t CrcEndIndex::target_of(std::size_t at) const {
    const std::size_t i = at - from_;
    const auto start = static_cast<std::uint16_t>(0xFFFFU ^ zero_runs_[i]);
    return shifted(kPlaces[start], static_cast<std::uint32_t>(i % kCycle));
}

}  // namespace rtuscope
