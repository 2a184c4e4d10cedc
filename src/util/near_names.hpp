// The names near a mistyped one, for "did you mean ...?" in messages.
#pragma once

#include <cstddef>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace rtuscope {

// Edits (insertions, deletions, substitutions) from `a` to `b`.
std::size_t edit_distance(std::string_view a, std::string_view b);

// Up to `limit` of `candidates` that `typed` may have meant, nearest first: those at most
// 2 edits away (1 for a name of up to 3 characters), then those that begin with or
// contain it (3 characters or more); each once.
std::vector<std::string> near_names(std::string_view typed,
                                    std::span<const std::string_view> candidates,
                                    std::size_t limit = 4);

}  // namespace rtuscope
