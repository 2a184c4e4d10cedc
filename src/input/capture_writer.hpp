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
// `header` says what goes into the file's header: the line settings, the program, the
// device map and the profiles to embed, as SourceInfo holds them once a capture is read.
Result<std::unique_ptr<ChunkSource>> record_capture(std::unique_ptr<ChunkSource> source,
                                                    const std::string& path,
                                                    const SourceInfo& header);

// The header of the capture format (docs/formats.md): "# rtuscope capture v1", then what
// `header` knows: "# serial 9600 8N1", "# written by rtuscope 0.1.0", "# device 3 pdu485"
// per slave, each embedded profile between "# profile NAME" and "# end profile" with its
// lines behind "#| ", and "# recorded live from PORT" when `header.name` is set.
std::string capture_header(const SourceInfo& header);

// One data line of the capture format: "1763798400.022360123 @A 01 03 ...\n".
std::string capture_line(const Chunk& chunk);

}  // namespace rtuscope
