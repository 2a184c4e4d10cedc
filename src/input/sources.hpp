// Stage 1, sources: readers for the input formats rtuscope decodes offline.
//   capture: the native text capture format v1 (docs/formats.md), timed chunks;
//   raw:     bytes only, no timing (cat /dev/ttyUSB0 > dump.bin);
//   hex:     bytes in hex a line at a time, as manuals and serial-terminal logs show them
//            (a line that is one frame is taken as it is, others are framed);
//   pcap:    pcap and pcapng files, one frame per packet (pcap.hpp).
#pragma once

#include <memory>
#include <string>
#include <string_view>

#include "input/chunk.hpp"
#include "input/pcap.hpp"
#include "util/result.hpp"

namespace rtuscope {

enum class InputFormat : std::uint8_t { automatic, capture, raw, hex, pcap };

// "auto", "capture", "raw", "hex", "pcap"
Result<InputFormat> parse_input_format(std::string_view name);
const char* to_string(InputFormat format);

// Guesses the format from the first bytes of the input (pcap/pcapng by magic number).
InputFormat detect_input_format(std::string_view head);

// Opens a file ("-" for standard input) and returns a source for it. Errors name the
// file and, for content errors found while opening (a bad header), the line and column.
// `pcap`: what the user says of a pcap's TCP and UDP traffic.
Result<std::unique_ptr<ChunkSource>> open_source(const std::string& path, InputFormat format,
                                                 const PcapOptions& pcap = {});

// The same over text or bytes already in memory (tests, fuzzers); `name` is used in
// messages.
Result<std::unique_ptr<ChunkSource>> source_from_memory(std::string content, std::string name,
                                                        InputFormat format,
                                                        const PcapOptions& pcap = {});

}  // namespace rtuscope
