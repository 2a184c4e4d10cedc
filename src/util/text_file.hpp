// Reading a whole small text file (a profile, a bus file) with errors worth showing: a
// directory or an unreadable file is a one-line message, not an exception or an empty
// file.
#pragma once

#include <string>

#include "util/result.hpp"

namespace rtuscope {

Result<std::string> read_text_file(const std::string& path);

}  // namespace rtuscope
