// Files rtuscope writes as a run goes on (sniff -w): plain, gzip or zstd, chosen by the
// name's extension. A compressed file is written in blocks, each a complete gzip member
// or zstd frame that decodes on its own, and a block ends at least every
// `block_interval`: whatever stops the run (SIGKILL, a power cut after the page cache
// reached the disk, an unplugged USB disk), every block already written decodes, so at
// most the last `block_interval` of data is lost. A plain file is written a write() per
// call and loses nothing that was written.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

#include "util/result.hpp"
#include "util/time.hpp"

namespace rtuscope {

enum class Compression : std::uint8_t { none, gzip, zstd };

// By the name's extension: ".gz" gzip, ".zst" zstd, anything else none.
Compression compression_for(std::string_view path);

struct OutputFileOptions {
    Compression compression = Compression::none;
    // A block ends once its first byte is this old (steady clock), at the next write()
    // or tick().
    Nanos block_interval = 2 * kNanosPerSecond;
    // ... or once it holds this many uncompressed bytes.
    std::size_t block_bytes = std::size_t{1} << 20;
};

class OutputFile {
  public:
    virtual ~OutputFile() = default;
    OutputFile(const OutputFile&) = delete;
    OutputFile& operator=(const OutputFile&) = delete;

    // Appends `bytes`; ends the block when it is due (OutputFileOptions).
    virtual Status write(std::string_view bytes) = 0;
    // Ends the block when it is due; the writer calls it while the line is idle, so that
    // a quiet line does not hold data back longer than the interval.
    virtual Status tick() = 0;
    // Ends the block now: what was written is on disk and decodes (a file's header, so
    // that a file never exists without one).
    virtual Status end_block() = 0;
    // Ends the last block and closes the file; the destructor closes silently.
    virtual Status close() = 0;
    // Bytes in the file so far (compressed), the blocks not yet ended excluded.
    [[nodiscard]] virtual std::uint64_t size() const = 0;
    // Bytes given to write() so far.
    [[nodiscard]] virtual std::uint64_t bytes_in() const = 0;
    [[nodiscard]] const std::string& path() const { return path_; }

  protected:
    explicit OutputFile(std::string path) : path_(std::move(path)) {}

  private:
    std::string path_;
};

// Creates (truncates) `path`. Errors name the file.
Result<std::unique_ptr<OutputFile>> create_output_file(const std::string& path,
                                                       const OutputFileOptions& options);

}  // namespace rtuscope
