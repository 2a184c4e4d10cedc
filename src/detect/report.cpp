// What `detect` prints: the settings ranked, the verdict and the evidence behind it.
#include <fmt/format.h>

#include <iterator>
#include <string>
#include <vector>

#include "detect/detect.hpp"
#include "util/text.hpp"

namespace rtuscope {
namespace {

std::string seconds(Nanos t) {
    return fmt::format("{:.1f} s", static_cast<double>(t) / 1e9);
}

std::string spacing(const SettingScore& s) {
    if (!s.timing) return "-";
    return fmt::format("{:.1f} bits",
                       static_cast<double>(s.timing->char_time) * s.line.baud / 1e9);
}

// "8E1, 8O1 and 8N2"
std::string formats_of(std::span<const SettingScore> settings) {
    std::string out;
    for (std::size_t i = 0; i < settings.size(); ++i) {
        if (i != 0) out += i + 1 == settings.size() ? " and " : ", ";
        out += settings[i].line.format();
    }
    return out;
}

}  // namespace

std::string answers_paired(std::uint64_t paired) {
    return paired == 1 ? std::string("1 answer paired with its request")
                       : fmt::format("{} answers paired with their requests", paired);
}

std::string line_options(const LineSettings& line) {
    return fmt::format("--baud {} --format {}", line.baud, line.format());
}

std::vector<std::string> detect_verdict(const DetectResult& r) {
    std::vector<std::string> out;
    const auto line = [&](std::string text) { out.push_back(std::move(text)); };
    if (r.quiet) {
        const SettingScore& s = r.ranked.front();
        line(fmt::format("No traffic in {} at {} {}: the line is quiet. Is the adapter on the "
                         "bus's A and B wires, and is a master polling?",
                         seconds(s.listened), s.line.baud, s.line.format()));
        return out;
    }
    if (r.alike == 0) {
        const SettingScore& s = r.ranked.front();
        line(fmt::format("No setting tried reads this line as Modbus RTU: the best, {} {}, puts "
                         "{:.0f} % of its bytes in frames with a valid CRC. Another protocol, or "
                         "a rate not tried (--bauds)?",
                         s.line.baud, s.line.format(), 100.0 * s.coverage()));
    } else {
        const SettingScore& s = r.ranked.front();
        std::string why = fmt::format(
            "{} {} with a valid CRC hold {:.0f} % of the bytes, {}", s.frames,
            plural(s.frames, "frame", "frames"), 100.0 * s.coverage(), answers_paired(s.paired));
        if (r.errors_reported) {
            why += s.char_errors == 0 ? std::string(", no parity or framing errors")
                                      : fmt::format(", {} parity or framing {}", s.char_errors,
                                                    plural(s.char_errors, "error", "errors"));
        }
        if (s.timing_fit == TimingFit::exact) {
            why += fmt::format(", bytes one {}-bit character apart", s.line.bits_per_char());
        }
        line(fmt::format("Best: {} {} (confidence {}): {}.", s.line.baud, s.line.format(),
                         r.confidence, why));
        if (r.alike > 1) {
            std::string reason;
            if (!r.errors_reported) {
                reason = "the port reported no parity or framing errors to tell them apart";
            } else {
                reason = "none of them gave parity or framing errors";
            }
            if (s.timing_fit == TimingFit::unknown) {
                reason += ", and its reads are too coarse to time single characters";
            }
            line(fmt::format("At {} baud {} read this line alike ({}); any of them decodes it. "
                             "{} is chosen as the most usual.",
                             s.line.baud,
                             formats_of(std::span(r.ranked).first(r.alike)), reason,
                             s.line.format()));
        }
    }
    if (r.cut_short) {
        line(fmt::format("Stopped after {} ({}) with {} settings tried.", seconds(r.listened),
                         r.interrupted ? "interrupted" : "--max-seconds", r.ranked.size()));
    }
    return out;
}

std::string format_detect_result(const DetectResult& r) {
    std::string out;
    if (!r.quiet) {
        fmt::format_to(std::back_inserter(out), "{:<11} {:>8} {:>7} {:>6} {:>6} {:>6} {:>6} {:>9} {:>6}\n",
                       "setting", "heard", "bytes", "frames", "valid", "paired", "errors",
                       "spacing", "score");
        for (const SettingScore& s : r.ranked) {
            fmt::format_to(std::back_inserter(out),
                           "{:<11} {:>8} {:>7} {:>6} {:>5.0f}% {:>6} {:>6} {:>9} {:>6.1f}\n",
                           fmt::format("{} {}", s.line.baud, s.line.format()),
                           seconds(s.listened), s.bytes, s.frames, 100.0 * s.coverage(),
                           s.paired, s.char_errors, spacing(s), s.score);
        }
        out += '\n';
    }
    for (const std::string& line : detect_verdict(r)) {
        out += line;
        out += '\n';
    }
    return out;
}

}  // namespace rtuscope
