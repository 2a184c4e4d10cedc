// toml++'s descriptions (toml++/impl/parser.inl, "Error while parsing SCOPE: DETAIL") of
// the mistakes people make by hand, said in plain words.
#include "profiles/toml_errors.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cstddef>
#include <optional>

namespace rtuscope {
namespace {

using std::string_view;

// Line `line` (1-based) of `text`, without its line break; empty past the end.
string_view line_of(string_view text, int line) {
    std::size_t start = 0;
    for (int l = 1; l < line; ++l) {
        const std::size_t newline = text.find('\n', start);
        if (newline == string_view::npos) return {};
        start = newline + 1;
    }
    const std::size_t end = std::min(text.find('\n', start), text.size());
    string_view s = text.substr(start, end - start);
    if (!s.empty() && s.back() == '\r') s.remove_suffix(1);
    return s;
}

// toml++ counts columns in code points; these convert them to and from byte offsets.
bool continues_code_point(char c) {
    return (static_cast<unsigned char>(c) & 0xC0U) == 0x80U;
}
std::size_t byte_at_column(string_view line, int column) {
    int seen = 0;
    for (std::size_t i = 0; i < line.size(); ++i) {
        if (!continues_code_point(line[i]) && ++seen == column) return i;
    }
    return line.size();
}
int column_at_byte(string_view line, std::size_t byte) {
    const auto end = line.begin() + static_cast<std::ptrdiff_t>(std::min(byte, line.size()));
    return 1 + static_cast<int>(std::count_if(line.begin(), end,
                                              [](char c) { return !continues_code_point(c); }));
}

string_view trim(string_view s) {
    while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
    while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
    return s;
}

// A string still open at the end of `line`, read as TOML reads it: a comment ends the
// line, a basic string ("...") has backslash escapes, a literal one ('...') has none,
// and either may be multi-line ("""...""").
struct OpenString {
    std::size_t at = 0;  // byte offset of its opening quote
    char quote = '"';
    bool multi_line = false;
};
std::optional<OpenString> open_string(string_view line) {
    std::size_t i = 0;
    while (i < line.size()) {
        const char quote = line[i];
        if (quote == '#') return std::nullopt;
        if (quote != '"' && quote != '\'') {
            ++i;
            continue;
        }
        const std::string triple(3, quote);
        const OpenString open{i, quote, line.substr(i, 3) == triple};
        i += open.multi_line ? 3 : 1;
        bool closed = false;
        while (i < line.size() && !closed) {
            if (quote == '"' && line[i] == '\\') {
                i += 2;
            } else if (line[i] == quote && (!open.multi_line || line.substr(i, 3) == triple)) {
                i += open.multi_line ? 3 : 1;
                closed = true;
            } else {
                ++i;
            }
        }
        if (!closed) return open;
    }
    return std::nullopt;
}

// What toml++ "saw" instead of what it expected: `X` of "..., saw 'X'" ("\n" stays the two
// characters toml++ writes), "comma" of "..., saw comma", empty when not said.
string_view saw(string_view detail) {
    const std::size_t at = detail.rfind("saw ");
    if (at == string_view::npos) return {};
    string_view what = detail.substr(at + 4);
    if (what.size() >= 2 && what.front() == '\'' && what.back() == '\'') {
        what = what.substr(1, what.size() - 2);
    }
    return what;
}
bool saw_line_end(string_view detail) {
    const string_view what = saw(detail);
    return what == "\\n" || what == "\\r" || detail.ends_with("end-of-file");
}
bool is_plain_char(string_view what) {
    return what.size() == 1 && std::isgraph(static_cast<unsigned char>(what[0])) != 0;
}

// The 'NAME' of "cannot redefine existing string 'NAME'", when it is a bare key (toml++
// garbles quoted ones).
std::optional<string_view> quoted_name(string_view detail) {
    const std::size_t open = detail.find('\'');
    const std::size_t close = detail.find('\'', open + 1);
    if (open == string_view::npos || close == string_view::npos) return std::nullopt;
    const string_view name = detail.substr(open + 1, close - open - 1);
    const bool bare = !name.empty() && std::all_of(name.begin(), name.end(), [](char c) {
        return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_' || c == '-';
    });
    return bare ? std::optional(name) : std::nullopt;
}

// Whether `line` gives bare `key` a value: "key = ...".
bool gives_key(string_view line, string_view key) {
    const string_view s = trim(line);
    if (!s.starts_with(key)) return false;
    const string_view rest = s.substr(key.size());
    return !rest.empty() && (rest.front() == ' ' || rest.front() == '\t' || rest.front() == '=');
}

// The line of the table above `line` where bare `key` is given first, or 0.
int earlier_key_line(string_view text, string_view key, int line) {
    for (int l = line - 1; l >= 1; --l) {
        const string_view s = line_of(text, l);
        if (trim(s).starts_with('[')) return 0;  // the table's header: not in this table
        if (gives_key(s, key)) return l;
    }
    return 0;
}

constexpr string_view kKeepBackslashes =
    "write \\\\ for a backslash, or put the text in 'single quotes', which keep backslashes "
    "as they are";

class Explainer {
  public:
    Explainer(string_view description, int line, int column, string_view text)
        : description_(description), text_(text), error_{line, column, {}} {
        constexpr string_view kLead = "Error while parsing ";
        const std::size_t colon = description.find(": ");
        if (description.starts_with(kLead) && colon != string_view::npos) {
            scope_ = description.substr(kLead.size(), colon - kLead.size());
            detail_ = description.substr(colon + 2);
        } else {
            detail_ = description;
        }
    }

    TomlSyntaxError explain() {
        error_.message = plain();
        if (error_.message.empty()) {
            // Not one of the common mistakes: toml++'s own words, all of them.
            std::string own(description_);
            if (own.starts_with("Error")) own[0] = 'e';
            error_.message = "not valid TOML: " + own;
        }
        return error_;
    }

  private:
    string_view description_;
    string_view text_;
    string_view scope_;
    string_view detail_;
    TomlSyntaxError error_;

    [[nodiscard]] bool detail_starts(string_view prefix) const {
        return detail_.starts_with(prefix);
    }
    [[nodiscard]] bool number_scope() const {
        return scope_.ends_with("integer") || scope_ == "floating-point";
    }
    void move_to(int line, std::size_t byte) {
        error_.line = line;
        error_.column = column_at_byte(line_of(text_, line), byte);
    }

    // The plain sentence, or empty for toml++'s own.
    std::string plain() {
        if (scope_ == "string" || scope_ == "literal string") return string_mistake();
        if (scope_ == "unicode scalar sequence" && detail_starts("expected hex digit")) {
            return fmt::format("a \\u or \\U escape needs 4 or 8 hex digits: {}", kKeepBackslashes);
        }
        if (scope_ == "table header") return header_mistake();
        if (scope_ == "key-value pair") return key_value_mistake();
        if (scope_ == "value" && detail_ == "could not determine value type") {
            return "a value is not a number, true, false, an [array], a { table } or a "
                   "\"string\": put text in quotes";
        }
        if (scope_ == "array") return array_mistake();
        if (scope_ == "inline table") return inline_table_mistake();
        if (number_scope()) return number_mistake();
        if (scope_ == "boolean") return "true and false are written in small letters";
        if (scope_ == "root table" && saw(detail_) == "=") {
            return "a line starts with =: the key is missing before it";
        }
        if (detail_ == "Encountered invalid utf-8 sequence") {
            return "the file is not UTF-8 text: save it as UTF-8";
        }
        return {};
    }

    std::string string_mistake() {
        const string_view line = line_of(text_, error_.line);
        const bool at_line_end = byte_at_column(line, error_.column) >= line.size();
        if (detail_starts("unknown escape sequence '")) {
            const std::size_t open = detail_.find('\'');
            const std::size_t close = detail_.rfind('\'');
            return fmt::format("a string has the unknown escape {}: {}",
                               detail_.substr(open + 1, close - open - 1), kKeepBackslashes);
        }
        const bool control = detail_.find("control characters") != string_view::npos;
        const bool eof = detail_ == "encountered end-of-file";
        if (control && !at_line_end) {
            return "a string holds a control character: remove it, or write it as an escape "
                   "such as \\n in a \"double-quoted\" string";
        }
        if (!control && !eof) return {};
        // The line ends inside a string: point at where it opens.
        if (const auto open = open_string(line); open && !open->multi_line) {
            move_to(error_.line, open->at);
            return fmt::format(
                "a string is not closed: add the missing {} at the end of the "
                "value",
                open->quote);
        }
        if (!eof) return {};
        // The file ends inside a multi-line string: it opens at the last triple quote.
        const std::string triple(3, scope_ == "string" ? '"' : '\'');
        const std::size_t at = text_.rfind(triple);
        if (at != string_view::npos) {
            const int line_number =
                1 + static_cast<int>(std::count(
                        text_.begin(), text_.begin() + static_cast<std::ptrdiff_t>(at), '\n'));
            const std::size_t line_start = text_.rfind('\n', at);
            move_to(line_number, line_start == string_view::npos ? at : at - line_start - 1);
        }
        return fmt::format("a multi-line string is not closed: add the missing {} at its end",
                           triple);
    }

    std::string header_mistake() {
        if (detail_starts("expected ']'") && (saw_line_end(detail_) || saw(detail_) == "#")) {
            const string_view line = line_of(text_, error_.line);
            string_view header = line.substr(0, line.find('#'));
            const std::size_t open = header.find('[');
            if (open == string_view::npos) return {};
            move_to(error_.line, open);
            header = trim(header.substr(open));
            const bool list = header.starts_with("[[");
            string_view name = header;
            while (!name.empty() && (name.front() == '[' || name.front() == ' ')) {
                name.remove_prefix(1);
            }
            while (!name.empty() && (name.back() == ']' || name.back() == ' ')) {
                name.remove_suffix(1);
            }
            if (name.empty()) return "a table header is not closed: end it with ]";
            return fmt::format("the table header {} is not closed: write {}{}{}", header,
                               list ? "[[" : "[", name, list ? "]]" : "]");
        }
        if (detail_starts("cannot redefine existing table '") && detail_.ends_with("'")) {
            if (const auto name = quoted_name(detail_)) {
                return fmt::format("the table [{}] is given twice: put its keys under one [{}]",
                                   *name, *name);
            }
        }
        if (detail_starts("cannot redefine existing table '") &&
            detail_.ends_with("as array-of-tables")) {
            if (const auto name = quoted_name(detail_)) {
                return fmt::format(
                    "[[{}]] here, but [{}] above is a single table: use one of "
                    "the two",
                    *name, *name);
            }
        }
        if (detail_starts("cannot redefine existing array '") && detail_.ends_with("as table")) {
            if (const auto name = quoted_name(detail_)) {
                return fmt::format(
                    "[{}] here, but [[{}]] above is a list of tables: write "
                    "[[{}]] for one more of them",
                    *name, *name, *name);
            }
        }
        if (detail_starts("expected a comment or whitespace")) {
            return "something follows the table header on its line (# starts a comment)";
        }
        return {};
    }

    std::string key_value_mistake() {
        if (detail_starts("cannot redefine existing ") && !detail_.ends_with("key-value pair")) {
            const auto name = quoted_name(detail_);
            if (!name) return "a key is given twice in one table: keep one";
            // Point at the key rather than at its value, when it starts the line.
            const string_view line = line_of(text_, error_.line);
            if (gives_key(line, *name)) {
                move_to(error_.line, line.find(*name));
            }
            const int earlier = earlier_key_line(text_, *name, error_.line);
            return fmt::format("the key \"{}\" is given twice in one table{}: keep one", *name,
                               earlier != 0 ? fmt::format(" (also at line {})", earlier) : "");
        }
        if (detail_starts("expected '='")) {
            if (saw_line_end(detail_))
                return "a key has no = and value after it: write key = value";
            const string_view what = saw(detail_);
            if (what.size() == 1 && (std::isalnum(static_cast<unsigned char>(what[0])) != 0 ||
                                     what == "_" || what == "-")) {
                return "a key has a space in it, or no = after it: write key = value, and a key "
                       "of several words in \"quotes\"";
            }
            return "a key is not followed by =: write key = value";
        }
        if (detail_starts("expected value") || detail_ == "encountered end-of-file") {
            return "a key has no value after its =: write key = value";
        }
        if (detail_starts("expected a comment or whitespace")) {
            return "something follows the value on its line: one key = value per line (# "
                   "starts a comment)";
        }
        return {};
    }

    std::string array_mistake() {
        if (detail_ == "encountered end-of-file")
            return "an array is not closed: add the missing ]";
        if (detail_starts("expected comma or closing ']'")) {
            return "an array needs a comma between its values and a ] at its end";
        }
        if (detail_starts("expected value or closing ']', saw comma")) {
            return "an array has a comma with no value before it: remove it";
        }
        return {};
    }

    std::string inline_table_mistake() {
        if (detail_starts("expected key-value pair, saw closing '}'")) {
            return "an inline table may not end with a comma: remove the , before }";
        }
        if (detail_starts("expected key-value pair or closing '}', saw comma")) {
            return "an inline table has a comma with no entry before it: remove it";
        }
        if ((detail_starts("expected key or closing '}'") ||
             detail_starts("expected comma or closing '}'") ||
             detail_ == "encountered end-of-file") &&
            saw_line_end(detail_)) {
            return "an inline table { ... } must end on the line where it starts: add the "
                   "missing }";
        }
        if (detail_starts("expected comma or closing '}'")) {
            return "an inline table needs a comma between its entries and a } at its end";
        }
        return {};
    }

    std::string number_mistake() {
        if (detail_ == "leading zeroes are prohibited") {
            return "a number may not start with 0: write 12, or 0x12 for hex";
        }
        if (detail_.ends_with("is not representable in 64 bits")) {
            return "a number is too large for 64 bits";
        }
        if (scope_ == "hexadecimal integer" && detail_ == "expected 'x', saw 'X'") {
            return "hex numbers start with 0x, with a small x";
        }
        const string_view what = saw(detail_);
        if (detail_starts("expected") && detail_.find("digit") != string_view::npos &&
            is_plain_char(what)) {
            return fmt::format(
                "a number has the character '{}' in it: write numbers like 42, "
                "0x2A or 0.5, and text in \"quotes\"",
                what);
        }
        return {};
    }
};

}  // namespace

TomlSyntaxError explain_toml_error(std::string_view description, int line, int column,
                                   std::string_view text) {
    return Explainer(description, line, column, text).explain();
}

}  // namespace rtuscope
