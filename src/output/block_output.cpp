#include "output/block_output.hpp"

#include <cerrno>
#include <system_error>

namespace rtuscope {
namespace {

[[noreturn]] void throw_output_error(int error) {
    throw std::system_error(error, std::generic_category(), "cannot write the output");
}

}  // namespace

void write_output(std::FILE* file, std::string_view text) {
    if (std::fwrite(text.data(), 1, text.size(), file) != text.size()) throw_output_error(errno);
}

void flush_output(std::FILE* file) {
    if (std::fflush(file) != 0) throw_output_error(errno);
}

}  // namespace rtuscope
