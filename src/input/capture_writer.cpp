#include "input/capture_writer.hpp"

#include <fmt/format.h>

#include <string_view>

#include "util/text.hpp"

namespace rtuscope {

namespace {

// "1763798400.022360123"; untimed chunks never come from a tty, "0" still makes a line
// the reader accepts.
std::string seconds_text(Nanos time) {
    if (!has_time(time)) return "0";
    const bool negative = time < 0;
    const auto magnitude = static_cast<std::uint64_t>(negative ? -(time + 1) + 1 : time);
    return fmt::format("{}{}.{:09}", negative ? "-" : "", magnitude / 1'000'000'000U,
                       magnitude % 1'000'000'000U);
}

}  // namespace

std::string capture_gap_line(Nanos from, Nanos to) {
    return fmt::format("# gap {} {} (the port was gone: nothing was heard)\n", seconds_text(from),
                       seconds_text(to));
}

std::string capture_line(const Chunk& chunk) {
    std::string line = seconds_text(chunk.time);
    if (!chunk.channel.empty()) line += " @" + chunk.channel;
    line += ' ';
    append_hex(line, chunk.bytes, true);
    line += '\n';
    return line;
}

std::string capture_header(const SourceInfo& header) {
    std::string text = "# rtuscope capture v1\n";
    if (header.line)
        text += fmt::format("# serial {} {}\n", header.line->baud, header.line->format());
    if (!header.written_by.empty()) text += fmt::format("# written by {}\n", header.written_by);
    for (const auto& [address, profile] : header.devices) {
        text += fmt::format("# device {} {}\n", address, profile);
    }
    for (const auto& [name, toml] : header.embedded_profiles) {
        text += fmt::format("# profile {}\n", name);
        std::string_view rest = toml;
        while (!rest.empty()) {
            const std::size_t end = std::min(rest.find('\n'), rest.size());
            text += "#| ";
            text += rest.substr(0, end);
            text += '\n';
            rest.remove_prefix(std::min(end + 1, rest.size()));
        }
        text += "# end profile\n";
    }
    if (!header.name.empty()) text += fmt::format("# recorded live from {}\n", header.name);
    return text;
}

}  // namespace rtuscope
