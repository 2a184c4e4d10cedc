// sniff -w: the raw chunks of a live line recorded in the native capture format (v1) as
// they pass, so that decoding the file later gives what the live run showed.
#pragma once

#include <memory>
#include <optional>
#include <string>

#include "framing/line_settings.hpp"
#include "input/chunk.hpp"
#include "util/result.hpp"

namespace rtuscope {

// Wraps `source`: every chunk it delivers is appended to `path` before it is handed on.
// Each chunk is one write() of one whole line, so the file is valid up to the last chunk
// received even when the process is killed; it is not fsync'ed (a power cut may lose
// the last seconds). A write error ends the run with that error.
Result<std::unique_ptr<ChunkSource>> record_capture(std::unique_ptr<ChunkSource> source,
                                                    const std::string& path);

// The header of the capture format: "# rtuscope capture v1\n", then "# serial 9600 8N1\n"
// when the line is known.
std::string capture_header(const std::optional<LineSettings>& line);

// One data line of the capture format: "1763798400.022360123 @A 01 03 ...\n".
std::string capture_line(const Chunk& chunk);

}  // namespace rtuscope
