// The one way the front end reports an error: "rtuscope: error: FILE:LINE:COL: message"
// on stderr, one line.
#pragma once

#include <fmt/format.h>

#include <cstdio>

#include "util/result.hpp"

namespace rtuscope::cli {

// An error with an empty message has already been reported line by line (every mistake
// of a profile file) and needs no summary.
inline void print_error(const Error& error) {
    if (error.message.empty()) return;
    fmt::print(stderr, "rtuscope: error: {}\n", error.to_string());
}

}  // namespace rtuscope::cli
