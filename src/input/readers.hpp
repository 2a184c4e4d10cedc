// Internal to the sources module: the buffered input every reader pulls from, the
// reader factories, and the helpers the readers share.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "input/chunk.hpp"
#include "util/result.hpp"
#include "util/time.hpp"

namespace rtuscope::detail {

// A line longer than this is not a capture or hex log line; without a limit a binary
// file read as text would grow the buffer to its own size.
inline constexpr std::size_t kMaxLineBytes = std::size_t{1} << 20;

// Bytes from memory or from a FILE*, read in large blocks and handed out as lines or
// blocks without copying. `initial` holds bytes already taken from the file (what format
// detection sniffed from a pipe) or, with no file, the whole input.
class InputBuffer {
  public:
    InputBuffer(std::string initial, std::FILE* file, bool close_file, std::string name);
    ~InputBuffer();
    InputBuffer(const InputBuffer&) = delete;
    InputBuffer& operator=(const InputBuffer&) = delete;

    // The next line without its "\n" or "\r\n"; false at the end of input. The view stays
    // valid until the next call.
    Result<bool> next_line(std::string_view& line);
    // Up to `max` bytes; false at the end of input. Valid until the next call.
    Result<bool> next_block(std::size_t max, std::string_view& block);
    // 1-based number of the line next_line returned last.
    [[nodiscard]] int line_number() const { return line_; }
    [[nodiscard]] const std::string& name() const { return name_; }

  private:
    // Makes room and reads more; false when nothing more can come.
    Result<bool> fill();

    std::string buf_;
    std::size_t pos_ = 0;   // first unconsumed byte
    std::size_t end_ = 0;   // end of valid bytes in buf_
    std::size_t scan_ = 0;  // no '\n' in [pos_, scan_)
    std::FILE* file_ = nullptr;
    bool close_file_ = false;
    bool eof_ = false;
    int line_ = 0;
    std::string name_;
};

std::unique_ptr<ChunkSource> make_raw_reader(std::unique_ptr<InputBuffer> in);
Result<std::unique_ptr<ChunkSource>> make_capture_reader(std::unique_ptr<InputBuffer> in);
Result<std::unique_ptr<ChunkSource>> make_hex_reader(std::unique_ptr<InputBuffer> in);

// Blank, or a comment line ('#' or "//" first): not a frame and not worth a remark.
bool is_blank_or_comment(std::string_view line);

// Hex digit values, -1 for anything else; a table because the capture reader looks up
// two digits per byte of a gigabyte capture.
inline constexpr std::array<std::int8_t, 256> kHexDigitValues = [] {
    std::array<std::int8_t, 256> table{};
    table.fill(-1);
    for (int i = 0; i < 10; ++i) table['0' + i] = static_cast<std::int8_t>(i);
    for (int i = 0; i < 6; ++i) {
        table['a' + i] = static_cast<std::int8_t>(10 + i);
        table['A' + i] = static_cast<std::int8_t>(10 + i);
    }
    return table;
}();

constexpr int hex_value(char c) {
    return kHexDigitValues[static_cast<unsigned char>(c)];
}

// A token shown in a message: bounded in length, control and non-ASCII bytes escaped, so
// a binary file read as text still gives a readable one-line message.
std::string quote_token(std::string_view token);

}  // namespace rtuscope::detail
