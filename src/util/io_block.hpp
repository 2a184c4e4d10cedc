// The block in which rtuscope reads its input and writes its output: 64 KiB. stdio's own
// buffer is a file's block size (4 KiB), a system call every few KiB; 1 MiB for stdout
// gains nothing more and costs 0.9 MiB of RSS.
#pragma once

#include <cstddef>
#include <cstdio>
#include <memory>

namespace rtuscope {

inline constexpr std::size_t kIoBlockBytes = std::size_t{64} << 10;

// Gives `file` a stdio buffer of kIoBlockBytes, for code that reads or writes it in small
// pieces (libpcap's two freads a packet, the pcap writer's packets). glibc takes a size
// only with a buffer to go with it. Call it before the file's first read or write (or
// just after a seek, when the buffer is empty), and keep what it returns until the file
// is closed.
inline std::unique_ptr<char[]> give_stdio_buffer(std::FILE* file) {
    auto buffer = std::make_unique_for_overwrite<char[]>(kIoBlockBytes);
    std::setvbuf(file, buffer.get(), _IOFBF, kIoBlockBytes);
    return buffer;
}

}  // namespace rtuscope
