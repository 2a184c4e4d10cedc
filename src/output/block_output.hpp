// Where the sinks' text goes: their file, in 64 KiB blocks, and what happens when the file
// refuses it.
#pragma once

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <string_view>

#include "util/io_block.hpp"

namespace rtuscope {

// Output to `file`, and what stdio holds for it handed to the system. A write the file
// refuses (a full disk, an I/O error) throws std::system_error ("cannot write the output:
// ..."), which ends the run: decoding on into an output that is lost would end in a
// truncated file and exit status 0.
void write_output(std::FILE* file, std::string_view text);
void flush_output(std::FILE* file);

// Text a sink builds in memory, handed to its file in blocks: one write per 64 KiB
// instead of one per record. send() hands over what is pending (the sinks call it on
// flush(), per record when live, and before anything they print directly).
class BlockOutput {
  public:
    explicit BlockOutput(std::FILE* file) : file_(file) {}
    BlockOutput(const BlockOutput&) = delete;
    BlockOutput& operator=(const BlockOutput&) = delete;
    // Cannot throw here: a failure is left in the file's error indicator, which main
    // checks before it exits.
    ~BlockOutput() {
        if (used_ > 0) std::fwrite(block_.get(), 1, used_, file_);
    }

    [[nodiscard]] std::FILE* file() const { return file_; }

    // A record written straight into the block: `write` gets where to write, at most
    // `bound` characters, and returns the end of what it wrote. The room is not filled
    // first, as a std::string's resize must (a memset of the whole bound per CSV row).
    template <class Write>
    void write(std::size_t bound, Write write) {
        make_room(bound);
        used_ = static_cast<std::size_t>(write(block_.get() + used_) - block_.get());
        if (used_ >= kIoBlockBytes) send();
    }

    // A record composed with std::string's appends (the text and JSONL sinks): line() is
    // where it goes, record_done() moves it into the block.
    std::string& line() { return line_; }
    void record_done() {
        write(line_.size(), [&](char* p) { return std::copy(line_.begin(), line_.end(), p); });
        line_.clear();
    }

    // A write the file refuses throws (see flush_output).
    void send() {
        if (used_ == 0) return;
        const std::size_t pending = used_;
        used_ = 0;
        write_output(file_, {block_.get(), pending});
    }
    // What is pending, and then what stdio holds, to the system.
    void flush() {
        send();
        flush_output(file_);
    }

  private:
    void make_room(std::size_t bound) {
        if (capacity_ - used_ >= bound) return;
        // Records are added below kIoBlockBytes (a full block is sent at once), so one block
        // and a record's bound is all the room there ever is, unless a record is larger.
        const std::size_t capacity = std::max(kIoBlockBytes, used_) + bound;
        auto larger = std::make_unique_for_overwrite<char[]>(capacity);
        if (used_ > 0) std::memcpy(larger.get(), block_.get(), used_);
        block_ = std::move(larger);
        capacity_ = capacity;
    }

    std::FILE* file_;
    std::unique_ptr<char[]> block_;
    std::size_t capacity_ = 0;
    std::size_t used_ = 0;
    std::string line_;
};

}  // namespace rtuscope
