#include "util/near_names.hpp"

#include <algorithm>
#include <tuple>

namespace rtuscope {

std::size_t edit_distance(std::string_view a, std::string_view b) {
    std::vector<std::size_t> row(b.size() + 1);
    for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
    for (std::size_t i = 1; i <= a.size(); ++i) {
        std::size_t diagonal = row[0];
        row[0] = i;
        for (std::size_t j = 1; j <= b.size(); ++j) {
            const std::size_t above = row[j];
            row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] != b[j - 1])});
            diagonal = above;
        }
    }
    return row[b.size()];
}

std::vector<std::string> near_names(std::string_view typed,
                                    std::span<const std::string_view> candidates,
                                    std::size_t limit) {
    const std::size_t max_edits = typed.size() <= 3 ? 1 : 2;
    // Edits first; a name that contains what was typed ranks after every near one.
    std::vector<std::tuple<std::size_t, std::string_view>> found;
    for (const std::string_view name : candidates) {
        if (name == typed) continue;
        const std::size_t edits = edit_distance(typed, name);
        if (edits <= max_edits) {
            found.emplace_back(edits, name);
        } else if (typed.size() >= 3 && name.find(typed) != std::string_view::npos) {
            found.emplace_back(max_edits + 1, name);
        }
    }
    std::sort(found.begin(), found.end());
    std::vector<std::string> names;
    for (const auto& [edits, name] : found) {
        if (names.size() == limit) break;
        if (std::find(names.begin(), names.end(), name) == names.end()) names.emplace_back(name);
    }
    return names;
}

}  // namespace rtuscope
