// Where a frame that starts at a given byte could end, by its CRC alone, for many starts
// over the same bytes: the framer's search for lengths no field gives.
//
// A frame of n bytes checks when the CRC register, run from 0xFFFF over all its bytes (its
// own CRC included), ends at 0. Testing every length from every start costs a CRC pass per
// start: through garbage, where every byte is a start, up to 256 bytes at each byte. But the
// register is linear in its bytes: with Z(k) the register run from 0 over the indexed bytes
// up to byte k, and A the step of one zero byte, the run from `at` ends at 0 after n bytes
// exactly when
//     Z(at + n) == A^n (0xFFFF ^ Z(at)).
// A permutes the 65536 register values in two cycles of 32767 values and two fixed points,
// 0 and 0xC001 (the modulus factors into x+1 and a primitive x^15+x+1; the unit test checks
// the cycles). Numbering each cycle's values along it, A^n moves a value n places on its
// cycle, so the test becomes key(at + n) == target(at), where key(k) is Z(k)'s cycle and its
// place on it less k. Keys are worked out once per byte for all starts, and a search is a
// scan of them for one number, eight at a time, made only when a count of the keys in a
// window sliding along with the searches says the number is there (garbage: rarely). A
// search from within another's `found` (the framer looking at what follows a length) has
// a window of its own, so that the two do not each start the other's afresh.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>
#include <span>
#include <vector>

#include "framing/crc.hpp"

namespace rtuscope {

class CrcEndIndex {
  public:
    // The bytes were moved or replaced: what was indexed is forgotten.
    void clear() {
        empty_windows();
        zero_runs_.clear();
        keys_.clear();
        unfound_ = 0;
        unfound_to_ = 0;
    }

    // For a frame starting at `bytes[at]`: calls `found(n)` for each length n in
    // [first, last] (at + last <= bytes.size()), shortest first, at which the CRC checks,
    // until it returns true; returns whether one did. `found` may itself search from a
    // later start (the index only grows then, so lengths are read by index, not pointer).
    template <class Found>
    bool find(std::span<const std::uint8_t> bytes, std::size_t at, std::size_t first,
              std::size_t last, Found found) {
        if (!indexed(at)) {
            // Most searches find a length a few bytes on (a frame of a code whose length
            // no field gives), or are a few in a short run of noise: a CRC per length
            // costs less than indexing. Only once several in a row have found nothing
            // over the same bytes, as through garbage, are the bytes indexed.
            if (at >= unfound_to_) unfound_ = 0;
            if (unfound_ < kUnfoundBeforeIndexing) {
                const bool hit = find_directly(bytes.subspan(at), first, last, found);
                unfound_ = hit ? 0 : unfound_ + 1;
                unfound_to_ = hit ? 0 : at + last;
                return hit;
            }
            start_at(at);
        }
        index_to(bytes, at);
        const std::uint16_t target = target_of(at);
        Window& window = windows_[std::min(depth_, windows_.size() - 1)];
        if (!may_hold(window, bytes, target, at + first, at + last + 1)) return false;
        // A search made by `found` counts with the next window.
        auto found_within = [&](std::size_t n) {
            ++depth_;
            const bool taken = found(n);
            --depth_;
            return taken;
        };
        std::size_t k = at + first;
        const std::size_t end = at + last + 1;
        // Indexed a block ahead of the scan, not to `last` at once: most searches outside
        // garbage end at a frame's length, a few bytes on.
        while (k < end) {
            const std::size_t block_end = std::min(end, k + kBlock);
            index_to(bytes, block_end - 1);
            for (; k + kLanes <= block_end; k += kLanes) {
                if (!any_of_8(&keys_[k - from_], target)) continue;
                for (std::size_t j = k; j < k + kLanes; ++j) {
                    if (keys_[j - from_] == target && found_within(j - at)) return true;
                }
            }
            for (; k < block_end; ++k) {
                if (keys_[k - from_] == target && found_within(k - at)) return true;
            }
        }
        return false;
    }

  private:
    [[nodiscard]] bool indexed(std::size_t at) const {
        return !keys_.empty() && at >= from_ && at - from_ < keys_.size();
    }

    // The CRC over each length: a frame checks when the CRC over all its bytes, its own
    // CRC (low byte first) included, is 0. Four lengths a step: each step waits for the
    // one before (table lookups), so four bytes a step quarter that wait.
    template <class Found>
    static bool find_directly(std::span<const std::uint8_t> head, std::size_t first,
                              std::size_t last, Found found) {
        std::size_t done = first - 1;
        std::uint16_t crc = crc16_modbus(head.first(done));  // of `done` bytes
        for (; done + 4 <= last; done += 4) {
            const auto after = crc16_modbus_each_of_4(crc, head.data() + done);
            for (std::size_t j = 0; j < 4; ++j) {
                if (after[j] == 0 && found(done + j + 1)) return true;
            }
            crc = after[3];
        }
        for (; done < last; ++done) {
            crc = crc16_modbus_byte(crc, head[done]);
            if (crc == 0 && found(done + 1)) return true;
        }
        return false;
    }

    static constexpr std::size_t kLanes = 8;
    static constexpr std::size_t kBlock = 32;
    static constexpr std::size_t kUnfoundBeforeIndexing = 4;
    using Lanes = std::uint16_t __attribute__((vector_size(2 * kLanes)));

    static bool any_of_8(const std::uint16_t* keys, std::uint16_t target) {
        Lanes lanes;
        std::memcpy(&lanes, keys, sizeof lanes);
        const Lanes equal = lanes == target;
        std::uint64_t halves[2];
        std::memcpy(halves, &equal, sizeof halves);
        return (halves[0] | halves[1]) != 0;
    }

    // How many keys of [from, to) have each value (made on first use: 64 KiB). A window is
    // never longer than kMaxWindow keys, so a count fits a byte.
    struct Window {
        std::vector<std::uint8_t> counts;
        std::size_t from = 0;
        std::size_t to = 0;
    };
    static constexpr std::size_t kMaxWindow = 255;

    // Whether a key in [from, to) may equal `target`: false only when none does. Through
    // garbage nearly every search finds nothing, and a scan of up to 253 keys per byte would
    // be most of the framer's work there; a count per key value over a window of the keys
    // that slides along with the searches answers it by one look. A search that starts
    // before the window or past its end starts it afresh there; one longer than a window
    // can be is answered "may" and scanned.
    bool may_hold(Window& window, std::span<const std::uint8_t> bytes, std::uint16_t target,
                  std::size_t from, std::size_t to);
    void empty(Window& window);
    void empty_windows();
    // Starts the index afresh at `at`.
    void start_at(std::size_t at);
    // Indexes the bytes up to `to`, inclusive (`to` at most bytes.size()).
    void index_to(std::span<const std::uint8_t> bytes, std::size_t to);
    [[nodiscard]] std::uint16_t target_of(std::size_t at) const;

    std::size_t from_ = 0;                  // the first indexed byte
    std::vector<std::uint16_t> zero_runs_;  // Z(from_ + i): the register run from 0
    std::vector<std::uint16_t> keys_;       // key(from_ + i)
    // Searches in a row that found no length, each from within the last one's bytes,
    // and where the last one ended.
    std::size_t unfound_ = 0;
    std::size_t unfound_to_ = 0;
    // A search's window, and that of the searches its `found` makes (a search per length
    // it offers, from where that length ends); deeper searches share the last.
    std::array<Window, 2> windows_;
    std::size_t depth_ = 0;  // searches under way
};

// The cycle and place of a register value under the zero-byte step (for the unit test):
// bit 15 the cycle, bits 0-14 the place (0-32766), 0x7FFF and 0xFFFF the fixed points.
std::uint16_t crc_cycle_place(std::uint16_t reg);

}  // namespace rtuscope
