#include "framing/line_check.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <optional>

namespace rtuscope {
namespace {

// Below this many bytes a share says nothing.
constexpr std::uint64_t kMinBytes = 64;
// Less than this share of the bytes in valid frames: not Modbus RTU at these settings.
constexpr double kMinValidShare = 0.05;

}  // namespace

void LineCheck::chunk(const Chunk& chunk) {
    bytes_ += chunk.bytes.size();
    char_time_.chunk(chunk);
    if (chunk.bytes.size() != 1 || !has_time(chunk.time)) {
        last_single_ = kNoTime;
        return;
    }
    if (has_time(last_single_) && chunk.time > last_single_) {
        const Nanos interval = chunk.time - last_single_;
        ++single_pairs_;
        // A little slack for the clock's resolution.
        if (interval < line_.char_time() * 9 / 10) ++too_soon_;
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
    // Back-to-back bytes are a character apart: the rate and character length their
    // spacing fits, when the header's rate fits none.
    const std::optional<CharTimeEstimate> estimate = char_time_.estimate();
    const std::vector<CharTimeFit> fits =
        estimate ? fit_char_time(estimate->char_time) : std::vector<CharTimeFit>{};
    const bool header_fits = std::any_of(fits.begin(), fits.end(), [&](const CharTimeFit& f) {
        return f.baud == line_.baud;
    });
    std::string suggestion;
    if (!fits.empty() && !header_fits) {
        suggestion = fmt::format("their spacing ({} µs) suggests {} baud with {}",
                                 estimate->char_time / 1000, fits.front().baud,
                                 describe_char_bits(fits.front().bits_per_char));
    }
    if (single_pairs_ >= 16 && too_soon_ * 2 >= single_pairs_) {
        out.push_back(
            fmt::format("bytes come sooner than a character takes at {} baud ({:.3f} ms): {} of {} "
                        "intervals between bytes timed one by one{}{}",
                        line_.baud, static_cast<double>(line_.char_time()) / 1e6, too_soon_,
                        single_pairs_, suggestion.empty() ? "" : "; ", suggestion));
    } else if (!suggestion.empty()) {
        // Slower than the header's rate: a sender pausing between characters would not
        // keep one spacing that fits another standard rate.
        out.push_back(fmt::format("bytes timed one by one are further apart than a character "
                                  "at {} baud ({:.3f} ms): {}",
                                  line_.baud, static_cast<double>(line_.char_time()) / 1e6,
                                  suggestion));
    }
    return out;
}

}  // namespace rtuscope
