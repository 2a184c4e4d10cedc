// Which settings are tried, in which order, for how long; and how they rank.
#include <algorithm>
#include <cmath>

#include "detect/detect.hpp"

namespace rtuscope {
namespace {

// A setting that reads the line this well needs no other rate tried.
constexpr double kReadsWell = 60.0;
// Below this nothing was found.
constexpr double kPlausible = 10.0;
// Settings within this share of the best score, whose timing says the same, read the
// line alike: the bytes heard at two settings come at different moments, and the first
// and last frames of each are cut where listening started and stopped.
constexpr double kAlike = 0.9;

// Timing that fits, or says nothing, counts alike; too slow or too fast for a format
// sets it apart.
bool timing_alike(TimingFit a, TimingFit b) {
    const auto fits = [](TimingFit t) { return t == TimingFit::exact || t == TimingFit::unknown; };
    return a == b || (fits(a) && fits(b));
}

// Formats in the order preferred among settings that read a line alike: even parity is
// Modbus's default (Modbus over Serial Line 2.5.1), 8N1 the most common otherwise, and
// 8N2 what the specification asks for without parity.
constexpr std::string_view kPreference[] = {"8E1", "8N1", "8N2", "8O1", "7E1",
                                            "7N2", "7O1", "8E2", "8O2", "7E2", "7O2"};

std::size_t preference(const LineSettings& line) {
    const std::string format = line.format();
    const auto* it = std::find(std::begin(kPreference), std::end(kPreference), format);
    return static_cast<std::size_t>(it - std::begin(kPreference));
}

LineSettings at(LineSettings format, std::uint32_t baud) {
    format.baud = baud;
    return format;
}

// Enough heard at a setting to judge it: a few frames' worth of bursts, or a while.
bool heard_enough(const LineSettings& line, std::span<const Chunk> chunks, Nanos listened,
                  Nanos min_dwell) {
    if (listened < min_dwell) return false;
    std::uint64_t bytes = 0;
    std::uint64_t bursts = 0;
    Nanos last = kNoTime;
    for (const Chunk& c : chunks) {
        bytes += c.bytes.size();
        if (!has_time(last) || c.time - last > line.t35()) ++bursts;
        last = c.time;
    }
    return bytes >= 64 && bursts >= 6;
}

}  // namespace

std::vector<LineSettings> default_formats(bool all_formats) {
    std::vector<std::string_view> names = {"8N1", "8E1", "8O1", "8N2"};
    if (all_formats) names.insert(names.end(), {"7E1", "7O1", "7N2", "8E2", "8O2", "7E2", "7O2"});
    std::vector<LineSettings> formats;
    formats.reserve(names.size());
    for (const std::string_view name : names) formats.push_back(*parse_line_format(name));
    return formats;
}

std::vector<std::uint32_t> default_bauds() {
    return {9600, 19200, 115200, 38400, 57600, 4800, 2400, 14400, 1200};
}

Result<DetectResult> detect_line(const Listen& listen, const DetectOptions& options) {
    DetectResult result;
    if (options.bauds.empty() || options.formats.empty()) {
        return Error{"no settings to try: give at least one baud rate and format"};
    }
    // Every rate at the first format, then the other formats rate by rate.
    std::vector<LineSettings> plan;
    for (const std::uint32_t baud : options.bauds) plan.push_back(at(options.formats[0], baud));
    for (const std::uint32_t baud : options.bauds) {
        for (std::size_t f = 1; f < options.formats.size(); ++f) {
            plan.push_back(at(options.formats[f], baud));
        }
    }

    const auto stopped = [&] { return options.stop != nullptr && options.stop->load(); };
    std::vector<Chunk> heard;
    std::optional<std::uint32_t> found_baud;
    for (std::size_t i = 0; i < plan.size(); ++i) {
        const LineSettings& line = plan[i];
        if (found_baud && line.baud != *found_baud) continue;
        const Nanos left = options.max_total - result.listened;
        if (left <= 0 || stopped()) {
            result.cut_short = true;
            result.interrupted = stopped();
            break;
        }
        heard.clear();
        // The first setting waits for the line's first byte: any traffic gives bytes at
        // any setting, so a line quiet at one is quiet.
        const bool first = i == 0;
        const Nanos most = std::min(left, first ? options.quiet_wait + options.max_dwell
                                                : options.max_dwell);
        Nanos first_byte = kNoTime;
        auto listened = listen(
            line, most,
            [&](std::span<const Chunk> chunks, Nanos so_far) {
                if (chunks.empty()) return false;
                if (!has_time(first_byte)) first_byte = so_far;
                const Nanos since = first ? so_far - first_byte : so_far;
                return heard_enough(line, chunks, since, options.min_dwell) ||
                       since >= options.max_dwell;
            },
            heard);
        if (!listened) return listened.error();
        result.listened += *listened;
        const SettingScore score = score_setting(line, heard, *listened);
        if (first && score.bytes == 0) {
            result.quiet = true;
            result.ranked.push_back(score);
            return result;
        }
        if (!found_baud && score.score >= kReadsWell) found_baud = line.baud;
        result.errors_reported = result.errors_reported || score.char_errors > 0;
        result.ranked.push_back(score);
    }

    auto& ranked = result.ranked;
    std::stable_sort(ranked.begin(), ranked.end(), [](const SettingScore& a, const SettingScore& b) {
        return a.score > b.score;
    });
    if (ranked.empty() || ranked.front().score < kPlausible) return result;
    const double best = ranked.front().score;
    const TimingFit best_timing = ranked.front().timing_fit;
    const auto alike_end =
        std::stable_partition(ranked.begin(), ranked.end(), [&](const SettingScore& s) {
            return s.score >= best * kAlike && timing_alike(s.timing_fit, best_timing);
        });
    std::stable_sort(ranked.begin(), alike_end, [](const SettingScore& a, const SettingScore& b) {
        return preference(a.line) < preference(b.line);
    });
    result.alike = static_cast<std::size_t>(alike_end - ranked.begin());
    result.chosen = ranked.front().line;
    const SettingScore& top = ranked.front();
    if (top.score >= 80 && top.frames >= 5 && top.paired >= 2) {
        result.confidence = "high";
    } else if (top.score >= 40 && top.frames >= 3) {
        result.confidence = "medium";
    } else {
        result.confidence = "low";
    }
    return result;
}

}  // namespace rtuscope
