// Several input files read as one stream: the files a rotated recording wrote
// (`decode 'bus-*.rtucap'`), in the order given, a frame cut at a file's end joined with
// its rest at the next one's start. Each file is opened when the one before it ends, so
// that a month of files does not hold a month of descriptors.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "input/sources.hpp"
#include "util/result.hpp"

namespace rtuscope {

// The files the arguments name: each as it is when it exists (or is "-"), else a glob
// pattern (`*`, `?`, `[`) expanded in name order, which is time order for the stamped
// names of a rotated recording. A pattern that matches nothing is an error.
Result<std::vector<std::string>> expand_inputs(const std::vector<std::string>& arguments);

// One source over `paths` (one path: open_source's). The first file's header says what
// the stream is (line settings, devices); a later file of another format or with other
// line settings, or one that starts before the file before it ends, is an error naming
// it.
Result<std::unique_ptr<ChunkSource>> open_joined(const std::vector<std::string>& paths,
                                                 InputFormat format, const PcapOptions& pcap);

}  // namespace rtuscope
