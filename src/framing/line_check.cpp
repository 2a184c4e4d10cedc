#include "framing/line_check.hpp"

#include <fmt/format.h>

#include <array>
#include <cmath>

namespace rtuscope {
namespace {

// Below this many bytes a share says nothing.
constexpr std::uint64_t kMinBytes = 64;
// Less than this share of the bytes in valid frames: not Modbus RTU at these settings.
constexpr double kMinValidShare = 0.05;
// Intervals kept for the rate estimate: up to 10 ms, in microseconds.
constexpr std::size_t kMaxIntervalMicros = 10'000;

}  // namespace

void LineCheck::chunk(const Chunk& chunk) {
    bytes_ += chunk.bytes.size();
    if (chunk.bytes.size() != 1 || !has_time(chunk.time)) {
        last_single_ = kNoTime;
        return;
    }
    if (has_time(last_single_) && chunk.time > last_single_) {
        const Nanos interval = chunk.time - last_single_;
        ++single_pairs_;
        // A little slack for the clock's resolution.
        if (interval < line_.char_time() * 9 / 10) ++too_soon_;
        const auto micros = static_cast<std::size_t>(interval / 1000);
        if (micros < kMaxIntervalMicros) {
            if (interval_counts_.empty()) interval_counts_.resize(kMaxIntervalMicros);
            ++interval_counts_[micros];
        }
    }
    last_single_ = chunk.time;
}

void LineCheck::frame(const Frame& frame) {
    if (frame.cls == RecordClass::frame && frame.crc.status != CrcStatus::bad) {
        valid_bytes_ += frame.bytes.size();
    }
}

std::vector<std::string> LineCheck::remarks() const {
    std::vector<std::string> out;
    if (bytes_ >= kMinBytes &&
        static_cast<double>(valid_bytes_) < kMinValidShare * static_cast<double>(bytes_)) {
        out.push_back(fmt::format(
            "this does not look like Modbus RTU at {} {}: only {:.1f} % of its {} bytes are in "
            "frames with a valid CRC (another baud rate or format? another protocol?)",
            line_.baud, line_.format(),
            100.0 * static_cast<double>(valid_bytes_) / static_cast<double>(bytes_), bytes_));
    }
    // Back-to-back bytes are a character apart: when most come sooner, the line is faster.
    if (single_pairs_ >= 16 && too_soon_ * 2 >= single_pairs_) {
        // The interval most bytes keep: the tenth percentile of those seen.
        std::uint64_t seen = 0;
        for (const std::uint32_t n : interval_counts_) seen += n;
        std::uint64_t counted = 0;
        std::size_t micros = 0;
        for (; micros < interval_counts_.size(); ++micros) {
            counted += interval_counts_[micros];
            if (counted * 10 >= seen) break;
        }
        std::string suggestion;
        if (seen != 0) {
            const double baud = line_.bits_per_char() * 1e6 / (static_cast<double>(micros) + 0.5);
            const std::uint32_t nearest = nearest_standard_baud(baud);
            suggestion = fmt::format("; their spacing ({} µs) suggests {} baud", micros, nearest);
        }
        out.push_back(
            fmt::format("bytes come sooner than a character takes at {} baud ({:.3f} ms): {} of {} "
                        "intervals between bytes timed one by one{}",
                        line_.baud, static_cast<double>(line_.char_time()) / 1e6, too_soon_,
                        single_pairs_, suggestion));
    }
    return out;
}

}  // namespace rtuscope
