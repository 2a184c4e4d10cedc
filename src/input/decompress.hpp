// Compressed input (gzip, zstd), read through a stream that decompresses as it goes, so
// that every reader takes a .gz or .zst file, or one on standard input, as it takes the
// plain one. Several members or frames one after the other (the blocks OutputFile writes)
// read as one stream.
#pragma once

#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <string_view>

#include "input/chunk.hpp"
#include "util/output_file.hpp"
#include "util/result.hpp"

namespace rtuscope {

// gzip or zstd by the magic number at the start of `head`, else none.
Compression compression_of(std::string_view head);

// "gzip member", "zstd frame": what a block of each is called.
const char* block_name(Compression compression);

// What the stream met: shared by the stream and the source reading through it, which
// turns it into the error or remark the user sees.
struct Decompression {
    Compression compression = Compression::none;
    std::string error;         // the data is corrupt: why, where; empty while it is not
    bool cut_off = false;      // the input ends inside a member or frame
    std::uint64_t blocks = 0;  // complete members or frames read
};

struct DecompressingStream {
    std::FILE* file = nullptr;  // the caller's to close; closing it closes `rest` if owned
    std::shared_ptr<const Decompression> state;
};

// A stream of `head` (bytes already taken from `rest`) then the rest of `rest`,
// decompressed. `close_rest`: closing the stream closes `rest` (also on failure here).
Result<DecompressingStream> open_decompressing(Compression compression, std::string head,
                                               std::FILE* rest, bool close_rest,
                                               const std::string& name);

// `source`, reading through a decompressing stream: its errors are the stream's when the
// data is corrupt, and a remark says where input cut off inside a block ends.
std::unique_ptr<ChunkSource> with_decompression(std::unique_ptr<ChunkSource> source,
                                                std::shared_ptr<const Decompression> state);

}  // namespace rtuscope
