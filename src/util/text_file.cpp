#include "util/text_file.hpp"

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace rtuscope {

Result<std::string> read_text_file(const std::string& path) {
    std::error_code ec;
    if (std::filesystem::is_directory(path, ec)) return Error{"is a directory", path};
    std::ifstream in(path, std::ios::binary);
    if (!in) return Error{std::string("cannot open: ") + std::strerror(errno), path};
    std::ostringstream text;
    text << in.rdbuf();
    if (in.bad()) return Error{std::string("cannot read: ") + std::strerror(errno), path};
    return text.str();
}

}  // namespace rtuscope
