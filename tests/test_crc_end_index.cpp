#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <random>
#include <vector>

#include "framing/crc.hpp"
#include "framing/crc_end_index.hpp"

namespace rtuscope {
namespace {

std::uint16_t zero_step(std::uint16_t reg) {
    return crc16_modbus_byte(reg, 0);
}

// What the index rests on: the zero-byte step moves every register value one place along
// its cycle (two cycles of 32767), except 0 and 0xC001, which it leaves where they are.
TEST(CrcEndIndex, ZeroByteStepMovesEveryValueOnePlaceAlongItsCycle) {
    int fixed = 0;
    int on_cycle[2] = {0, 0};
    for (std::uint32_t v = 0; v < 65536; ++v) {
        const auto reg = static_cast<std::uint16_t>(v);
        const std::uint16_t place = crc_cycle_place(reg);
        const std::uint16_t next = crc_cycle_place(zero_step(reg));
        if ((place & 0x7FFFU) == 0x7FFFU) {
            ++fixed;
            EXPECT_EQ(zero_step(reg), reg) << v;
            continue;
        }
        ++on_cycle[place >> 15U];
        EXPECT_EQ(next >> 15U, place >> 15U) << v;
        EXPECT_EQ(next & 0x7FFFU, ((place & 0x7FFFU) + 1U) % 32767U) << v;
    }
    EXPECT_EQ(fixed, 2);
    EXPECT_EQ(on_cycle[0], 32767);
    EXPECT_EQ(on_cycle[1], 32767);
    EXPECT_EQ(crc_cycle_place(0), 0x7FFF);
    EXPECT_EQ(crc_cycle_place(0xC001), 0xFFFF);
}

// The lengths in [first, last] at which a frame at `at` checks, by a CRC per length.
std::vector<std::size_t> checked_lengths(const std::vector<std::uint8_t>& bytes, std::size_t at,
                                         std::size_t first, std::size_t last) {
    std::vector<std::size_t> lengths;
    for (std::size_t n = first; n <= last; ++n) {
        const auto frame = std::span(bytes).subspan(at, n);
        if (crc16_modbus(frame) == 0) lengths.push_back(n);
    }
    return lengths;
}

// Bytes where lengths are found: random ones with frames planted in them (some running
// into each other), a run of zeros and one of 0xFF.
std::vector<std::uint8_t> test_bytes(std::mt19937& random, std::size_t size) {
    std::vector<std::uint8_t> bytes(size);
    for (auto& b : bytes) b = static_cast<std::uint8_t>(random());
    std::fill_n(bytes.begin() + 100, 300, 0x00);
    std::fill_n(bytes.begin() + 700, 50, 0xFF);
    for (std::size_t i = 0; i < size / 25; ++i) {
        const std::size_t n = 4 + random() % 40;
        const std::size_t at = random() % (size - n);
        const std::uint16_t crc = crc16_modbus(std::span(bytes).subspan(at, n - 2));
        bytes[at + n - 2] = static_cast<std::uint8_t>(crc & 0xFFU);
        bytes[at + n - 1] = static_cast<std::uint8_t>(crc >> 8U);
    }
    return bytes;
}

TEST(CrcEndIndex, FindsTheLengthsACrcPerLengthFinds) {
    std::mt19937 random(7);
    const std::vector<std::uint8_t> bytes = test_bytes(random, 3000);
    CrcEndIndex index;
    std::size_t found_any = 0;
    // Starts forward one by one (the framer's resync), then jumps back and far ahead
    // (the index starts over), with windows of every size up to a whole ADU.
    std::vector<std::size_t> starts;
    for (std::size_t at = 0; at < 1200; ++at) starts.push_back(at);
    for (int i = 0; i < 400; ++i) starts.push_back(random() % 2700);
    for (const std::size_t at : starts) {
        const std::size_t last = std::min<std::size_t>(4 + random() % 253, bytes.size() - at);
        if (last < 4) continue;
        std::vector<std::size_t> lengths;
        EXPECT_FALSE(index.find(bytes, at, 4, last, [&](std::size_t n) {
            lengths.push_back(n);
            return false;
        }));
        ASSERT_EQ(lengths, checked_lengths(bytes, at, 4, last)) << "from " << at;
        found_any += lengths.size();
        if (random() % 50 == 0) index.clear();
    }
    EXPECT_GT(found_any, 30U);  // the planted frames
}

// Where the register lands on a fixed point of the zero-byte step: two bytes that run
// the register from 0 to 0xFFFF, then FF FF (the CRC of no bytes) and zeros. From byte 2
// on, every length checks (the register started at 0xFFFF is 0 after FF FF and stays 0
// through the zeros), and the index, started at byte 0, sees 0xFFFF ^ 0xFFFF = 0 there.
TEST(CrcEndIndex, FixedPointsAndTheFirstLengthTaken) {
    std::vector<std::uint8_t> bytes(2);
    for (std::uint32_t pair = 0; pair < 65536; ++pair) {
        bytes[0] = static_cast<std::uint8_t>(pair);
        bytes[1] = static_cast<std::uint8_t>(pair >> 8U);
        if (crc16_modbus_update(0, bytes) == 0xFFFF) break;
    }
    ASSERT_EQ(crc16_modbus_update(0, bytes), 0xFFFF);
    bytes.push_back(0xFF);
    bytes.push_back(0xFF);
    bytes.resize(200, 0x00);

    CrcEndIndex index;
    std::vector<std::size_t> from_0;
    index.find(bytes, 0, 4, 150, [&](std::size_t n) {
        from_0.push_back(n);
        return false;
    });
    EXPECT_EQ(from_0, checked_lengths(bytes, 0, 4, 150));

    const std::vector<std::size_t> all = checked_lengths(bytes, 2, 4, 150);
    ASSERT_EQ(all.size(), 147U);  // every length
    std::vector<std::size_t> offered;
    EXPECT_TRUE(index.find(bytes, 2, 4, 150, [&](std::size_t n) {
        offered.push_back(n);
        return offered.size() == 3;  // the third length offered is taken
    }));
    EXPECT_EQ(offered, (std::vector<std::size_t>{4, 5, 6}));
}

// The framer confirms a length by looking at what follows, which may search again from
// the frame's end: the outer search must go on unharmed.
TEST(CrcEndIndex, ASearchInsideASearchLeavesItWhole) {
    std::mt19937 random(3);
    const std::vector<std::uint8_t> bytes = test_bytes(random, 2000);
    for (std::size_t at = 0; at < 1500; at += 7) {
        CrcEndIndex index;
        std::vector<std::size_t> outer;
        index.find(bytes, at, 4, 256, [&](std::size_t n) {
            outer.push_back(n);
            const std::size_t next = at + n;
            const std::size_t last = std::min<std::size_t>(256, bytes.size() - next);
            if (last >= 4) {
                std::vector<std::size_t> inner;
                index.find(bytes, next, 4, last, [&](std::size_t m) {
                    inner.push_back(m);
                    return false;
                });
                EXPECT_EQ(inner, checked_lengths(bytes, next, 4, last)) << at << "+" << n;
            }
            return false;
        });
        EXPECT_EQ(outer, checked_lengths(bytes, at, 4, 256)) << at;
    }
}

// Through garbage a search that finds nothing is answered from a count of the keys in a
// window that slides along with the searches: a length at either edge of a search, with
// the window left by the searches before it (a byte back, from later starts, around a
// hit) and of every size from one key to a whole ADU, must still be found.
TEST(CrcEndIndex, FindsLengthsAtTheEdgesOfEverySearch) {
    std::mt19937 random(11);
    const std::vector<std::uint8_t> bytes = test_bytes(random, 4000);
    CrcEndIndex index;
    auto lengths_from = [&](std::size_t at, std::size_t first, std::size_t last) {
        std::vector<std::size_t> lengths;
        index.find(bytes, at, first, last, [&](std::size_t n) {
            lengths.push_back(n);
            return false;
        });
        return lengths;
    };
    std::size_t edges = 0;
    for (std::size_t at = 0; at + 4 <= bytes.size(); ++at) {
        const std::size_t most = std::min<std::size_t>(256, bytes.size() - at);
        const std::vector<std::size_t> all = checked_lengths(bytes, at, 4, most);
        // A window ending on the first length, one starting on the last, one of just it.
        const std::size_t shortest = all.empty() ? 4 + random() % (most - 3) : all.front();
        ASSERT_EQ(lengths_from(at, 4, shortest), checked_lengths(bytes, at, 4, shortest)) << at;
        const std::size_t longest = all.empty() ? shortest : all.back();
        ASSERT_EQ(lengths_from(at, longest, most), checked_lengths(bytes, at, longest, most)) << at;
        ASSERT_EQ(lengths_from(at, longest, longest), checked_lengths(bytes, at, longest, longest))
            << at;
        edges += all.size();
        // What follows a frame is searched from its end, and then a start a byte back.
        if (random() % 3 == 0) {
            const std::size_t later = std::min(bytes.size() - 4, at + 1 + random() % 300);
            const std::size_t last = std::min<std::size_t>(256, bytes.size() - later);
            ASSERT_EQ(lengths_from(later, 4, last), checked_lengths(bytes, later, 4, last))
                << later;
        }
        // Garbage further on: the index starts over there, and again back here.
        if (random() % 40 == 0) {
            const std::size_t far = std::min(bytes.size() - 4, at + 500 + random() % 1000);
            for (std::size_t start = far; start < std::min(bytes.size() - 3, far + 6); ++start) {
                const std::size_t last = std::min<std::size_t>(256, bytes.size() - start);
                ASSERT_EQ(lengths_from(start, 4, last), checked_lengths(bytes, start, 4, last))
                    << start;
            }
        }
        if (at > 0 && random() % 5 == 0) {
            const std::size_t last = std::min<std::size_t>(256, bytes.size() - at + 1);
            ASSERT_EQ(lengths_from(at - 1, 4, last), checked_lengths(bytes, at - 1, 4, last))
                << at - 1;
        }
    }
    EXPECT_GT(edges, 100U);  // the planted frames and the runs of zeros and FF
}

// A per-byte capture of garbage: each new byte repeats the search from where the framer
// waits, a byte longer, and a hit in it the search of what follows from the hit's end,
// again a byte longer. The two searches alternate, each with its own window, over bytes
// that are now and then replaced (the index is cleared) or from starts that jump back
// or far ahead (it starts over with both windows counting: both must start over too).
TEST(CrcEndIndex, SearchesAlternatingWithTheSearchesInsideThemFindEveryLength) {
    std::mt19937 random(5);
    CrcEndIndex index;
    std::size_t inner_searches = 0;
    std::size_t jumps = 0;
    for (int round = 0; round < 3; ++round) {
        const std::vector<std::uint8_t> bytes = test_bytes(random, 3000);
        index.clear();
        for (std::size_t at = 0; at + 4 <= bytes.size(); at += 1 + random() % 40) {
            if (random() % 8 == 0) {
                ++jumps;
                at = random() % 2 == 0 ? at / 2 : at + 300 + random() % 300;
                if (at + 4 > bytes.size()) break;
            }
            const std::size_t most = std::min<std::size_t>(256, bytes.size() - at);
            for (std::size_t last = 4; last <= most; last += 1 + random() % 5) {
                std::vector<std::size_t> outer;
                index.find(bytes, at, 4, last, [&](std::size_t n) {
                    outer.push_back(n);
                    const std::size_t next = at + n;
                    const std::size_t inner_last = std::min(last, bytes.size() - next);
                    if (inner_last < 4) return false;
                    std::vector<std::size_t> inner;
                    index.find(bytes, next, 4, inner_last, [&](std::size_t m) {
                        inner.push_back(m);
                        return false;
                    });
                    ++inner_searches;
                    EXPECT_EQ(inner, checked_lengths(bytes, next, 4, inner_last))
                        << round << ": " << at << "+" << n << " to " << inner_last;
                    return false;
                });
                ASSERT_EQ(outer, checked_lengths(bytes, at, 4, last))
                    << round << ": " << at << " to " << last;
            }
        }
    }
    EXPECT_GT(inner_searches, 1000U);
    EXPECT_GT(jumps, 20U);
}

}  // namespace
}  // namespace rtuscope
