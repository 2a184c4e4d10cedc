// Opening and setting up a serial port, shared by the sniffer's source and the detector's
// listener.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "framing/line_settings.hpp"
#include "input/chunk.hpp"
#include "input/tty.hpp"
#include "util/result.hpp"

namespace rtuscope {

// The one-line error for a port that does not open, with the fix where there is one.
Error open_error(const std::string& path, int err);

// Which errors the port marks in its stream (PARMRK): parity errors where the format has
// parity (as a sniffer set to the line's format needs), or framing errors too whatever
// the format (a detector telling formats apart).
enum class ErrorMarks : std::uint8_t { as_the_format_checks, parity_and_framing };

// Raw mode at the line's speed and character format, errors marked, low latency where the
// driver allows (what it refuses goes to `notices`); what was buffered is dropped.
Status configure_port(int fd, const std::string& path, const LineSettings& line,
                      ErrorMarks marks, std::vector<std::string>& notices);

// Appends what one read() of the port gives to `chunk`: its bytes, unescaped by `parmrk`,
// and the offsets of those received with an error. Nothing when the read would block or
// was interrupted; a port that hung up (`revents` from poll) is an error saying so.
Status read_marked(int fd, const std::string& path, short revents, ParmrkDecoder& parmrk,
                   Chunk& chunk);

}  // namespace rtuscope
