#include "framing/char_time.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>

#include "framing/line_settings.hpp"

namespace rtuscope {
namespace {

// Enough to estimate from, and a bound on memory over a long capture.
constexpr std::size_t kMaxIntervals = 1 << 16;
constexpr std::uint64_t kMinAgreeing = 16;
// Intervals within this ratio of each other count as one spacing: a clock's resolution
// and a reader's wake-up jitter.
constexpr double kSameSpacing = 1.03;
constexpr double kMaxFitError = 0.04;

}  // namespace

void CharTimeEstimator::chunk(const Chunk& chunk) {
    if (chunk.bytes.size() != 1 || !has_time(chunk.time)) {
        last_single_ = kNoTime;
        return;
    }
    if (has_time(last_single_) && chunk.time > last_single_ && intervals_.size() < kMaxIntervals) {
        intervals_.push_back(chunk.time - last_single_);
    }
    last_single_ = chunk.time;
}

void CharTimeEstimator::reset() {
    last_single_ = kNoTime;
    intervals_.clear();
}

// The densest spacing: the window [x, x * 1.03] holding the most intervals, and their
// median. Pauses between frames and a sender's gaps between characters are longer and
// fewer; a reader woken late makes one interval long and the next short, around it.
std::optional<CharTimeEstimate> CharTimeEstimator::estimate() const {
    if (intervals_.size() < kMinAgreeing) return std::nullopt;
    std::vector<Nanos> sorted = intervals_;
    std::sort(sorted.begin(), sorted.end());
    std::size_t best_from = 0;
    std::size_t best_count = 0;
    std::size_t to = 0;
    for (std::size_t from = 0; from < sorted.size(); ++from) {
        const double limit = static_cast<double>(sorted[from]) * kSameSpacing;
        to = std::max(to, from);
        while (to < sorted.size() && static_cast<double>(sorted[to]) <= limit) ++to;
        if (to - from > best_count) {
            best_count = to - from;
            best_from = from;
        }
    }
    // A spacing that few intervals keep is a reader's jitter, not the line's.
    if (best_count < kMinAgreeing || best_count * 10 < sorted.size() * 3) return std::nullopt;
    return CharTimeEstimate{sorted[best_from + best_count / 2], best_count, sorted.size()};
}

std::vector<CharTimeFit> fit_char_time(Nanos char_time, std::span<const std::uint32_t> bauds) {
    static constexpr std::array<std::uint32_t, 12> kBauds = {
        1200, 2400, 4800, 9600, 14400, 19200, 28800, 38400, 57600, 76800, 115200, 230400};
    if (bauds.empty()) bauds = kBauds;
    std::vector<CharTimeFit> fits;
    if (char_time <= 0) return fits;
    for (const std::uint32_t baud : bauds) {
        for (unsigned bits = 10; bits <= 12; ++bits) {
            const double expected =
                static_cast<double>(bits) * static_cast<double>(kNanosPerSecond) / baud;
            const double error = std::abs(std::log(static_cast<double>(char_time) / expected));
            if (error <= kMaxFitError) fits.push_back({baud, bits, error});
        }
    }
    std::sort(fits.begin(), fits.end(),
              [](const CharTimeFit& a, const CharTimeFit& b) { return a.error < b.error; });
    return fits;
}

std::string describe_char_bits(unsigned bits_per_char) {
    switch (bits_per_char) {
        case 10:
            return "10-bit characters (8N1, 7E1, 7O1 or 7N2)";
        case 11:
            return "11-bit characters (8E1, 8O1 or 8N2; or 8N1 with a bit's pause between "
                   "characters)";
        case 12:
            return "12-bit characters (8E2 or 8O2)";
        default:
            return fmt::format("{}-bit characters", bits_per_char);
    }
}

}  // namespace rtuscope
