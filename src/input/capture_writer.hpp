// The native capture format (v1, docs/formats.md) written: its header and its data lines,
// for sniff -w (src/recording) and for the tools that convert to it.
#pragma once

#include <memory>
#include <optional>
#include <string>

#include "framing/line_settings.hpp"
#include "input/chunk.hpp"
#include "util/result.hpp"

namespace rtuscope {

// The header of the capture format (docs/formats.md): "# rtuscope capture v1", then what
// `header` knows: "# serial 9600 8N1", "# written by rtuscope 0.1.0", "# device 3 pdu485"
// per slave, each embedded profile between "# profile NAME" and "# end profile" with its
// lines behind "#| ", and "# recorded live from PORT" when `header.name` is set.
std::string capture_header(const SourceInfo& header);

// One data line of the capture format: "1763798400.022360123 @A 01 03 ...\n".
std::string capture_line(const Chunk& chunk);

// The line saying that nothing was heard between two times because the port was gone
// (sniff --reopen): "# gap 1763798400.022360123 1763798461.500000000 (...)\n".
std::string capture_gap_line(Nanos from, Nanos to);

}  // namespace rtuscope
