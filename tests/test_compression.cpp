// Compressed captures: what OutputFile writes in blocks decodes through open_source to the
// bytes written, a block ends on time, a run killed loses at most its unended block, and
// a file cut off or corrupt reads as docs/formats.md says.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "input/decompress.hpp"
#include "input/sources.hpp"
#include "support.hpp"
#include "util/output_file.hpp"

namespace rtuscope {
namespace {

using test::TempDir;

struct Decoded {
    std::string bytes;
    std::vector<std::string> remarks;
    std::optional<Error> error;
};

// Every byte the raw reader gives of `path`, then its remarks or its error.
Decoded decode_raw(const std::string& path) {
    Decoded out;
    Result<std::unique_ptr<ChunkSource>> source = open_source(path, InputFormat::raw);
    if (!source) {
        out.error = source.error();
        return out;
    }
    Chunk chunk;
    for (;;) {
        Result<bool> more = (*source)->next(chunk);
        if (!more) {
            out.error = more.error();
            break;
        }
        if (!*more) break;
        out.bytes.append(chunk.bytes.begin(), chunk.bytes.end());
    }
    out.remarks = (*source)->remarks();
    return out;
}

std::string read_file(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

// Lines that differ one from the next and compress as capture text does: `n` of them.
std::string numbered_lines(int first, int n) {
    std::string out;
    for (int i = first; i < first + n; ++i) {
        out += std::to_string(i) + ".000123 01 03 00 " + std::to_string(i % 251) + " 00 02\n";
    }
    return out;
}

class CompressedOutput : public ::testing::TestWithParam<Compression> {
  protected:
    [[nodiscard]] std::string name(const std::string& stem) const {
        return dir_.file(stem + (GetParam() == Compression::zstd ? ".zst" : ".gz"));
    }
    [[nodiscard]] OutputFileOptions options(std::size_t block_bytes, Nanos interval) const {
        OutputFileOptions o;
        o.compression = GetParam();
        o.block_bytes = block_bytes;
        o.block_interval = interval;
        return o;
    }
    TempDir dir_;
};

constexpr Nanos kHour = 3600 * kNanosPerSecond;
constexpr Nanos kMilli = kNanosPerSecond / 1000;

TEST_P(CompressedOutput, DecodesToExactlyTheBytesWrittenOverManyBlocks) {
    const std::string path = name("many");
    auto file = create_output_file(path, options(4096, kHour));
    ASSERT_TRUE(file) << file.error().to_string();
    std::string written;
    int sizes_seen = 0;
    std::uint64_t last_size = 0;
    // Writes of every size from 1 byte to more than a block, binary bytes among them.
    for (int i = 0; i < 600; ++i) {
        std::string piece = numbered_lines(i * 7, i % 13);
        piece.append(static_cast<std::size_t>(i % 5000 == 0 ? 9000 : i % 3), static_cast<char>(i));
        ASSERT_TRUE((*file)->write(piece));
        written += piece;
        if ((*file)->size() != last_size) ++sizes_seen;
        last_size = (*file)->size();
    }
    EXPECT_EQ((*file)->bytes_in(), written.size());
    ASSERT_TRUE((*file)->close());
    EXPECT_GT(sizes_seen, 20);  // many blocks
    EXPECT_EQ((*file)->size(), std::filesystem::file_size(path));
    EXPECT_LT((*file)->size(), written.size() / 3);
    const Decoded decoded = decode_raw(path);
    ASSERT_FALSE(decoded.error) << decoded.error->to_string();
    EXPECT_TRUE(decoded.bytes == written);
    EXPECT_TRUE(decoded.remarks.empty());
}

TEST_P(CompressedOutput, AutomaticFormatSeesTheTextInside) {
    const std::string path = name("capture");
    const std::string capture =
        "# rtuscope capture v1\n# serial 9600 8N1\n0.010 01 03 00 00 00 01 84 0A\n";
    auto file = create_output_file(path, options(16, kHour));
    ASSERT_TRUE(file);
    ASSERT_TRUE((*file)->write(capture));
    ASSERT_TRUE((*file)->close());
    Result<std::unique_ptr<ChunkSource>> source = open_source(path, InputFormat::automatic);
    ASSERT_TRUE(source) << source.error().to_string();
    EXPECT_EQ((*source)->info().format, "capture");
    ASSERT_TRUE((*source)->info().line);
    EXPECT_EQ((*source)->info().line->baud, 9600U);
    Chunk chunk;
    ASSERT_TRUE(*(*source)->next(chunk));
    EXPECT_EQ(chunk.bytes.size(), 8U);
}

TEST_P(CompressedOutput, BlockEndsOnlyOnceItsFirstByteIsIntervalOld) {
    const Nanos interval = 200 * kMilli;
    const std::string path = name("interval");
    auto file = create_output_file(path, options(std::size_t{1} << 20, interval));
    ASSERT_TRUE(file);
    const Nanos before = clock_ns(CLOCK_MONOTONIC);
    ASSERT_TRUE((*file)->write("first\n"));
    ASSERT_TRUE((*file)->tick());
    // Not due yet, unless the machine paused this long between the two calls.
    if ((*file)->size() != 0) {
        EXPECT_GE(clock_ns(CLOCK_MONOTONIC) - before, interval);
    }
    std::this_thread::sleep_for(std::chrono::nanoseconds(interval + 10 * kMilli));
    ASSERT_TRUE((*file)->tick());
    const std::uint64_t ended = (*file)->size();
    EXPECT_GT(ended, 0U);
    EXPECT_EQ(std::filesystem::file_size(path), ended);
    // On disk and whole while the file is still open: what a killed run leaves.
    const Decoded decoded = decode_raw(path);
    ASSERT_FALSE(decoded.error);
    EXPECT_EQ(decoded.bytes, "first\n");
    EXPECT_TRUE(decoded.remarks.empty());
    ASSERT_TRUE((*file)->close());
}

TEST_P(CompressedOutput, QuietTickKeepsAYoungBlockAndBytesEndIt) {
    const std::string path = name("bytes");
    auto file = create_output_file(path, options(100, kHour));
    ASSERT_TRUE(file);
    ASSERT_TRUE((*file)->write(std::string(60, 'a')));
    ASSERT_TRUE((*file)->tick());
    EXPECT_EQ((*file)->size(), 0U);
    // 60 + 60 would pass 100: the first 60 end as a block of their own.
    ASSERT_TRUE((*file)->write(std::string(60, 'b')));
    const std::uint64_t one_block = (*file)->size();
    EXPECT_GT(one_block, 0U);
    EXPECT_EQ(decode_raw(path).bytes, std::string(60, 'a'));
    ASSERT_TRUE((*file)->write(std::string(40, 'c')));  // 100: full
    EXPECT_GT((*file)->size(), one_block);
    EXPECT_EQ(decode_raw(path).bytes,
              std::string(60, 'a') + std::string(60, 'b') + std::string(40, 'c'));
    ASSERT_TRUE((*file)->close());
}

// Blocks of `block` bytes each, one write each; the size on disk after each.
std::vector<std::uint64_t> write_blocks(const std::string& path, Compression compression,
                                        const std::string& data, std::size_t block) {
    OutputFileOptions o;
    o.compression = compression;
    o.block_bytes = block;
    o.block_interval = kHour;
    auto file = create_output_file(path, o);
    EXPECT_TRUE(file);
    std::vector<std::uint64_t> ends;
    for (std::size_t at = 0; at < data.size(); at += block) {
        EXPECT_TRUE((*file)->write(data.substr(at, block)));
        ends.push_back((*file)->size());
    }
    EXPECT_TRUE((*file)->close());
    return ends;
}

TEST_P(CompressedOutput, FileCutInsideABlockReadsItsWholeBlocksAndSaysSo) {
    const std::string path = name("cut");
    const std::string data = numbered_lines(0, 400);
    const std::size_t block = 1000;
    const std::vector<std::uint64_t> ends = write_blocks(path, GetParam(), data, block);
    ASSERT_GE(ends.size(), 10U);
    // Cut in the middle of the sixth block.
    std::filesystem::resize_file(path, (ends[4] + ends[5]) / 2);
    const Decoded decoded = decode_raw(path);
    ASSERT_FALSE(decoded.error) << decoded.error->to_string();
    EXPECT_TRUE(decoded.bytes == data.substr(0, 5 * block));
    ASSERT_FALSE(decoded.remarks.empty());
    EXPECT_NE(decoded.remarks[0].find("the file ends inside a"), std::string::npos)
        << decoded.remarks[0];
    EXPECT_NE(decoded.remarks[0].find("the 5 complete"), std::string::npos) << decoded.remarks[0];
}

TEST_P(CompressedOutput, CorruptBlockIsAnErrorNamingTheFileAfterTheBlocksBefore) {
    const std::string path = name("corrupt");
    const std::string data = numbered_lines(0, 400);
    const std::size_t block = 1000;
    const std::vector<std::uint64_t> ends = write_blocks(path, GetParam(), data, block);
    ASSERT_GE(ends.size(), 10U);
    std::string bytes = read_file(path);
    bytes[(ends[4] + ends[5]) / 2] ^= 0x55;
    std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
    const Decoded decoded = decode_raw(path);
    ASSERT_TRUE(decoded.error);
    EXPECT_EQ(decoded.error->file, path);
    EXPECT_EQ(decoded.error->message.find("corrupt "), 0U) << decoded.error->message;
    EXPECT_EQ(decoded.error->message.find('\n'), std::string::npos);
    // The blocks before it come first, and nothing of the block that fails its check.
    EXPECT_TRUE(decoded.bytes == data.substr(0, 5 * block));
}

TEST_P(CompressedOutput, GarbageAfterTheLastBlockIsAnError) {
    const std::string path = name("trailing");
    write_blocks(path, GetParam(), numbered_lines(0, 50), 500);
    std::ofstream(path, std::ios::binary | std::ios::app) << "not compressed at all\n";
    const Decoded decoded = decode_raw(path);
    ASSERT_TRUE(decoded.error);
    EXPECT_EQ(decoded.error->message.find("corrupt "), 0U) << decoded.error->message;
    EXPECT_EQ(decoded.bytes, numbered_lines(0, 50));
}

// A child writes numbered lines through an OutputFile, ticking while it writes, and tells
// the parent through a pipe how many bytes are in ended blocks each time the size on disk
// grows; the parent kills it with SIGKILL. What decodes holds at least what the child said
// was ended, and is a prefix of what it wrote.
TEST_P(CompressedOutput, SigkillLosesAtMostTheUnendedBlock) {
    const std::string path = name("killed");
    const Nanos interval = 30 * kMilli;
    int fds[2];
    ASSERT_EQ(::pipe(fds), 0);
    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
        ::close(fds[0]);
        auto file = create_output_file(path, options(std::size_t{1} << 20, interval));
        if (!file) ::_exit(2);
        std::uint64_t reported = 0;
        for (int i = 0;; ++i) {
            const std::string line = numbered_lines(i, 1);
            if (!(*file)->write(line)) ::_exit(3);
            if ((*file)->size() != reported) {
                reported = (*file)->size();
                // Every byte given so far is in an ended block: a block ends after the
                // write that makes it due.
                const std::uint64_t ended = (*file)->bytes_in();
                if (::write(fds[1], &ended, sizeof ended) != sizeof ended) ::_exit(4);
            }
            if (i % 64 == 0) std::this_thread::sleep_for(std::chrono::microseconds(200));
        }
    }
    ::close(fds[1]);
    // Some blocks first, then the kill, wherever the child is.
    std::uint64_t ended = 0;
    int reports = 0;
    while (reports < 5 && ::read(fds[0], &ended, sizeof ended) == sizeof ended) ++reports;
    const int killed = ::kill(child, SIGKILL);
    int status = 0;
    ASSERT_EQ(::waitpid(child, &status, 0), child);
    ASSERT_EQ(killed, 0);
    ASSERT_EQ(reports, 5) << "the child ended with status " << status;
    ASSERT_TRUE(WIFSIGNALED(status));
    // Whatever the child said before it died.
    std::uint64_t value = 0;
    while (::read(fds[0], &value, sizeof value) == sizeof value) ended = value;
    ::close(fds[0]);

    const Decoded decoded = decode_raw(path);
    ASSERT_FALSE(decoded.error) << decoded.error->to_string();
    EXPECT_GE(decoded.bytes.size(), ended);
    // What was written is the numbered lines from 0 on.
    const int lines =
        static_cast<int>(std::count(decoded.bytes.begin(), decoded.bytes.end(), '\n'));
    const std::string expected = numbered_lines(0, lines + 1);
    EXPECT_TRUE(expected.starts_with(decoded.bytes));
    // Blocks end between writes: the file decodes to whole lines.
    EXPECT_TRUE(decoded.bytes.empty() || decoded.bytes.back() == '\n');
}

INSTANTIATE_TEST_SUITE_P(Compression, CompressedOutput,
                         ::testing::Values(Compression::gzip, Compression::zstd),
                         [](const ::testing::TestParamInfo<Compression>& param) {
                             return std::string(param.param == Compression::zstd ? "zstd" : "gzip");
                         });

TEST(CompressionMagic, GzipNeedsItsMethodAndClearReservedFlags) {
    EXPECT_EQ(compression_of(std::string_view("\x1F\x8B\x08\x00", 4)), Compression::gzip);
    EXPECT_EQ(compression_of(std::string_view("\x28\xB5\x2F\xFD", 4)), Compression::zstd);
    // A raw dump can start with 1F 8B (slave 31, an exception to function 11).
    EXPECT_EQ(compression_of(std::string_view("\x1F\x8B\x02\x00", 4)), Compression::none);
    EXPECT_EQ(compression_of(std::string_view("\x1F\x8B\x08\xE0", 4)), Compression::none);
    EXPECT_EQ(compression_of("\x1F\x8B"), Compression::none);
}

TEST(CompressionMagic, RawDumpStartingLikeGzipIsReadAsItIs) {
    TempDir dir;
    const std::string bytes("\x1F\x8B\x02\x00\x05", 5);
    const std::string path = dir.write("dump.bin", bytes);
    const Decoded decoded = decode_raw(path);
    ASSERT_FALSE(decoded.error);
    EXPECT_EQ(decoded.bytes, bytes);
}

TEST(CompressionMagic, FileCutInsideItsFirstBlockHasNothingToDecode) {
    TempDir dir;
    const std::string path = dir.write("header.gz", std::string("\x1F\x8B\x08\x00\x00\x00", 6));
    Result<std::unique_ptr<ChunkSource>> source = open_source(path, InputFormat::automatic);
    ASSERT_FALSE(source);
    EXPECT_EQ(source.error().file, path);
    EXPECT_EQ(source.error().message,
              "ends inside its first gzip member (cut off before it was complete): nothing to "
              "decode");
}

}  // namespace
}  // namespace rtuscope
