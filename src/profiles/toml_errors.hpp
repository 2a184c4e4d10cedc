// TOML syntax errors in plain words. toml++ stops at the first one and names it in a
// parser's terms ("Error while parsing key-value pair: expected '=', saw '\"'"); profiles
// and bus files are written by hand, so their authors get what is wrong and, where it
// helps, what to write instead.
#pragma once

#include <string>
#include <string_view>

namespace rtuscope {

struct TomlSyntaxError {
    int line = 0;  // 1-based
    int column = 0;
    std::string message;
};

// The common mistakes (a string or a table header left open, a missing `=` or value, a
// key or table given twice, a bad number, a bad escape...) in plain words, at the place
// to look: where the open string starts rather than where the line ends. Anything else
// keeps toml++'s own description. `description`, `line` and `column` are those of
// toml++'s parse_error; `text` is the document it was parsing.
TomlSyntaxError explain_toml_error(std::string_view description, int line, int column,
                                   std::string_view text);

}  // namespace rtuscope
