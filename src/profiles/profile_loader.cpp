// Reads a device profile (TOML, docs/profiles.md) and checks it. Users write these
// files by hand, so every mistake is collected with its position rather than stopping at
// the first: `profiles check` should list them all in one go.
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include "decode/pdu_decoders.hpp"
#include "profiles/profile.hpp"
#include "profiles/profile_formula.hpp"
#include "profiles/toml.hpp"
#include "profiles/toml_errors.hpp"
#include "util/text_file.hpp"

namespace rtuscope {
namespace {

// One formula may not expand to more registers than a register space holds; this also
// keeps a mistyped range ([1, 100000]) from eating the machine.
constexpr std::size_t kMaxFormulaRegisters = 65536;

const std::set<std::string, std::less<>> kStandardTables = {"holding", "input", "coil", "discrete"};

class Loader {
  public:
    explicit Loader(std::string file) : file_(std::move(file)) {}

    ProfileLoad load(std::string_view text) {
        toml::table root;
        try {
            root = toml::parse(text, file_);
        } catch (const toml::parse_error& err) {
            // toml++ stops at the first syntax error: nothing after it can be checked.
            const SourcePos pos = pos_of(err.source());
            TomlSyntaxError e = explain_toml_error(err.description(), pos.line, pos.column, text);
            problems_.push_back({file_, e.line, e.column, std::move(e.message)});
            return finish();
        }
        check_keys(root, {"device", "function", "register"}, "at the top level");
        if (const toml::node* device = root.get("device")) {
            if (const toml::table* t = device->as_table()) {
                read_device(*t);
            } else {
                problem(*device, "device must be a table: [device]");
            }
        } else {
            problem(root, "missing [device] table");
        }
        for_each_table(root, "function", [this](const toml::table& t) { read_function(t); });
        for_each_table(root, "register", [this](const toml::table& t) { read_register(t); });
        check_registers();
        return finish();
    }

  private:
    std::string file_;
    Profile profile_;
    std::vector<ProfileProblem> problems_;
    // The tables the [[function]]s name, for the registers' `table`.
    std::set<std::string, std::less<>> function_tables_;
    // Registers whose length is unknown (a mistyped type, a string without a length):
    // checked for duplicate names, but not for overlaps, which their length would decide.
    std::vector<Register> unsized_;

    ProfileLoad finish() {
        std::stable_sort(problems_.begin(), problems_.end(),
                         [](const ProfileProblem& a, const ProfileProblem& b) {
                             return std::tie(a.line, a.column) < std::tie(b.line, b.column);
                         });
        // A formula gone wrong can repeat one mistake hundreds of times; the first ones
        // say enough.
        constexpr std::size_t kMaxProblems = 50;
        if (problems_.size() > kMaxProblems) {
            const std::size_t more = problems_.size() - kMaxProblems;
            problems_.resize(kMaxProblems);
            problems_.push_back({file_, 0, 0, fmt::format("... and {} more problems", more)});
        }
        ProfileLoad load;
        if (problems_.empty()) {
            profile_.file = file_;
            load.profile = std::move(profile_);
        }
        load.problems = std::move(problems_);
        return load;
    }

    static SourcePos pos_of(const toml::source_region& region) {
        return {static_cast<int>(region.begin.line), static_cast<int>(region.begin.column)};
    }
    void problem(const toml::source_region& region, std::string message) {
        const SourcePos pos = pos_of(region);
        problems_.push_back({file_, pos.line, pos.column, std::move(message)});
    }
    void problem(const toml::node& node, std::string message) {
        problem(node.source(), std::move(message));
    }
    void problem(SourcePos pos, std::string message) {
        problems_.push_back({file_, pos.line, pos.column, std::move(message)});
    }

    void check_keys(const toml::table& table, std::initializer_list<std::string_view> known,
                    std::string_view where) {
        for (const auto& [key, node] : table) {
            if (std::find(known.begin(), known.end(), key.str()) == known.end()) {
                std::string list;
                for (std::string_view k : known)
                    list += (list.empty() ? "" : ", ") + std::string(k);
                problem(key.source().begin.line != 0 ? key.source() : node.source(),
                        fmt::format("unknown key \"{}\" {} (known: {})", key.str(), where, list));
            }
        }
    }

    template <class Fn>
    void for_each_table(const toml::table& root, std::string_view key, Fn fn) {
        const toml::node* node = root.get(key);
        if (node == nullptr) return;
        const toml::array* list = node->as_array();
        if (list == nullptr) {
            problem(*node, fmt::format("{} must be an array of tables: [[{}]]", key, key));
            return;
        }
        for (const toml::node& entry : *list) {
            if (const toml::table* t = entry.as_table()) {
                fn(*t);
            } else {
                problem(entry, fmt::format("each [[{}]] must be a table", key));
            }
        }
    }

    // Typed getters: a wrong type is a problem at the value; absent gives nullopt.
    std::optional<std::string> get_string(const toml::table& t, std::string_view key) {
        const toml::node* node = t.get(key);
        if (node == nullptr) return std::nullopt;
        if (auto v = node->value_exact<std::string>()) return *v;
        problem(*node, fmt::format("{} must be a string", key));
        return std::nullopt;
    }
    std::optional<std::int64_t> get_integer(const toml::table& t, std::string_view key,
                                            std::int64_t min, std::int64_t max) {
        const toml::node* node = t.get(key);
        if (node == nullptr) return std::nullopt;
        const auto v = node->value_exact<std::int64_t>();
        if (!v || *v < min || *v > max) {
            problem(*node, fmt::format("{} must be an integer from {} to {}", key, min, max));
            return std::nullopt;
        }
        return *v;
    }
    std::optional<double> get_number(const toml::node& node, std::string_view what) {
        if (auto v = node.value_exact<double>()) return *v;
        if (auto v = node.value_exact<std::int64_t>()) return static_cast<double>(*v);
        problem(node, fmt::format("{} must be a number", what));
        return std::nullopt;
    }
    std::optional<bool> get_bool(const toml::table& t, std::string_view key) {
        const toml::node* node = t.get(key);
        if (node == nullptr) return std::nullopt;
        if (auto v = node->value_exact<bool>()) return *v;
        problem(*node, fmt::format("{} must be true or false", key));
        return std::nullopt;
    }
    // `[first, last]` of integers within min..max, first <= last.
    std::optional<std::pair<std::int64_t, std::int64_t>> get_int_pair(const toml::node& node,
                                                                      std::string_view what,
                                                                      std::int64_t min,
                                                                      std::int64_t max) {
        const toml::array* a = node.as_array();
        std::optional<std::int64_t> lo;
        std::optional<std::int64_t> hi;
        if (a != nullptr && a->size() == 2) {
            lo = (*a)[0].value_exact<std::int64_t>();
            hi = (*a)[1].value_exact<std::int64_t>();
        }
        if (!lo || !hi || *lo < min || *hi > max || *lo > *hi) {
            problem(node, fmt::format("{} must be [first, last], integers from {} to {}", what, min,
                                      max));
            return std::nullopt;
        }
        return std::pair(*lo, *hi);
    }

    void read_device(const toml::table& t) {
        check_keys(t,
                   {"name", "title", "source", "line", "addresses", "broadcast",
                    "exception_answers", "max_registers"},
                   "in [device]");
        if (auto name = get_string(t, "name")) {
            const bool good = !name->empty() && std::all_of(name->begin(), name->end(), [](char c) {
                return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-';
            });
            if (good) {
                profile_.name = *name;
            } else {
                problem(*t.get("name"), fmt::format("name \"{}\" must be lower case letters, "
                                                    "digits and -",
                                                    *name));
            }
        } else if (t.get("name") == nullptr) {
            problem(t, "[device] needs a name");
        }
        profile_.title = get_string(t, "title").value_or("");
        profile_.source = get_string(t, "source").value_or("");
        if (auto line = get_string(t, "line")) {
            auto settings = parse_line_settings(*line);
            if (settings) {
                profile_.line = *settings;
            } else {
                problem(*t.get("line"), settings.error().message);
            }
        }
        if (const toml::node* node = t.get("addresses")) {
            if (auto pair = get_int_pair(*node, "addresses", 0, 255)) {
                profile_.first_address = static_cast<std::uint8_t>(pair->first);
                profile_.last_address = static_cast<std::uint8_t>(pair->second);
            }
        }
        if (auto b = get_integer(t, "broadcast", 1, 255)) {
            profile_.broadcast = static_cast<std::uint8_t>(*b);
        }
        if (auto e = get_bool(t, "exception_answers")) profile_.exception_answers = *e;
        if (auto m = get_integer(t, "max_registers", 1, 65535)) {
            profile_.max_registers = static_cast<std::uint16_t>(*m);
        }
    }

    // A [[function]]: the standard entry of its code with what the file says instead. Its
    // data is the profile's (its layout, of its table), not the standard's. Every key is
    // checked even when the code is missing or repeated, so that one pass finds them all.
    void read_function(const toml::table& t) {
        check_keys(t, {"code", "name", "request_length", "answer", "layout", "table"},
                   "in [[function]]");
        const auto code = get_integer(t, "code", 1, 127);
        if (!code && t.get("code") == nullptr) problem(t, "[[function]] needs a code");
        FunctionSpec f = own_function(static_cast<std::uint8_t>(code.value_or(0)));
        const bool repeated = code && profile_.function(f.code) != nullptr;
        if (repeated) {
            problem(*t.get("code"), fmt::format("function 0x{:02X} is defined twice", f.code));
        }
        if (auto name = get_string(t, "name")) f.name = *name;
        const auto request_length = get_integer(t, "request_length", 4, 256);
        if (request_length) {
            f.request_length = LengthRule::fixed(static_cast<std::uint16_t>(*request_length));
        }
        if (auto answer = get_string(t, "answer")) {
            if (*answer == "echo") {
                f.answer = Answer::echo;
            } else if (*answer == "none") {
                f.answer = Answer::none;
            } else if (*answer != "standard") {
                problem(*t.get("answer"), fmt::format("answer \"{}\" must be \"standard\", "
                                                      "\"echo\" or \"none\"",
                                                      *answer));
            }
        }
        if (auto layout = get_string(t, "layout")) {
            if (const PduDecoder decoder = device_layout_decoder(*layout)) {
                f.decode_request = f.decode_response = decoder;
                if (request_length && *request_length != 8) {
                    problem(*t.get("request_length"),
                            "request_length must be 8 with layout \"address_value\" (address, "
                            "function, 2+2 data bytes, CRC)");
                }
            } else {
                problem(*t.get("layout"),
                        fmt::format("layout \"{}\" must be \"address_value\"", *layout));
            }
        }
        if (auto table = get_string(t, "table")) {
            f.device_table = *table;
            // Known to the registers below even when this function has a mistake: an
            // "unknown table" for each of them would only repeat it.
            function_tables_.insert(*table);
        }
        if (code && !repeated) profile_.functions.push_back(std::move(f));
    }

    // `{ "0x0A" = "label" }`: keys are numbers (decimal or 0x hex) up to `max`.
    std::map<std::uint32_t, std::string> read_labels(const toml::node& node, std::string_view key,
                                                     std::uint32_t max) {
        std::map<std::uint32_t, std::string> labels;
        const toml::table* t = node.as_table();
        if (t == nullptr) {
            problem(node, fmt::format("{} must be a table like {{ \"1\" = \"on\" }}", key));
            return labels;
        }
        for (const auto& [k, v] : *t) {
            const auto number = parse_number(k.str());
            const auto& where = k.source().begin.line != 0 ? k.source() : v.source();
            if (!number || *number > max) {
                problem(where, fmt::format("{} key \"{}\" must be a number from 0 to {}", key,
                                           k.str(), max));
                continue;
            }
            const auto label = v.value_exact<std::string>();
            if (!label) {
                problem(v, fmt::format("{} \"{}\" must be a string", key, k.str()));
                continue;
            }
            if (!labels.emplace(*number, *label).second) {
                problem(where, fmt::format("{} key \"{}\" repeats an earlier key", key, k.str()));
            }
        }
        return labels;
    }

    // `{ device_class = "energy", state_class = "total" }`: Home Assistant's names, lower
    // case with underscores; "" for none.
    void read_home_assistant(const toml::node& node, Register& r) {
        const toml::table* t = node.as_table();
        if (t == nullptr) {
            problem(node, "home_assistant must be a table like { device_class = \"energy\" }");
            return;
        }
        for (const auto& [key, value] : *t) {
            const auto& where = key.source().begin.line != 0 ? key.source() : value.source();
            if (key.str() != "device_class" && key.str() != "state_class") {
                problem(where, fmt::format("unknown key \"{}\" in home_assistant (device_class, "
                                           "state_class)",
                                           key.str()));
            }
        }
        if (auto device_class = get_string(*t, "device_class")) {
            const bool good = std::all_of(device_class->begin(), device_class->end(), [](char c) {
                return (c >= 'a' && c <= 'z') || c == '_';
            });
            if (good) {
                r.ha_device_class = *device_class;
            } else {
                problem(*t->get("device_class"),
                        fmt::format("device_class \"{}\" must be lower-case letters and _, as "
                                    "Home Assistant names them (\"energy\", \"power\"), or \"\"",
                                    *device_class));
            }
        }
        if (auto state_class = get_string(*t, "state_class")) {
            static constexpr std::array<std::string_view, 4> kStateClasses = {
                "measurement", "total", "total_increasing", ""};
            if (std::find(kStateClasses.begin(), kStateClasses.end(), *state_class) !=
                kStateClasses.end()) {
                r.ha_state_class = *state_class;
            } else {
                problem(*t->get("state_class"),
                        fmt::format("state_class \"{}\" must be \"measurement\", \"total\", "
                                    "\"total_increasing\" or \"\"",
                                    *state_class));
            }
        }
    }

    static std::optional<std::uint32_t> parse_number(std::string_view text) {
        int base = 10;
        if (text.starts_with("0x") || text.starts_with("0X")) {
            text.remove_prefix(2);
            base = 16;
        }
        std::uint32_t value = 0;
        const auto* end = text.data() + text.size();
        const auto [ptr, ec] = std::from_chars(text.data(), end, value, base);
        if (text.empty() || ec != std::errc{} || ptr != end) return std::nullopt;
        return value;
    }

    static bool good_name(std::string_view name) {
        return !name.empty() && std::all_of(name.begin(), name.end(), [](char c) {
            return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_' || c == '.' ||
                   c == '-';
        });
    }

    void read_register(const toml::table& t) {
        static const std::vector<std::string_view> kKeys = {
            "table",       "address", "formula",  "name",  "type",   "word_order",
            "length",      "scale",   "decimals", "unit",  "access", "range",
            "description", "values",  "bits",     "writes", "home_assistant"};
        Register r;
        r.pos = pos_of(t.source());
        // A register with a mistake still takes its place in the checks of the whole
        // profile (overlaps, duplicate names) as far as what it says can be read: the
        // user sees every mistake at once, not one more after each fix.
        bool sized = true;       // its length is known
        bool formula_ok = true;  // its formula and the variables' ranges can be read

        // A formula's variables are extra keys; anything else unknown is a mistake.
        std::optional<Formula> formula;
        if (auto text = get_string(t, "formula")) {
            auto parsed = parse_formula(*text);
            if (parsed) {
                formula = std::move(*parsed);
            } else {
                problem(*t.get("formula"), "bad formula: " + parsed.error().message);
            }
        }
        std::vector<FormulaVariable> variables;
        for (const auto& [key, node] : t) {
            if (std::find(kKeys.begin(), kKeys.end(), key.str()) != kKeys.end()) continue;
            // A formula that does not parse cannot say which keys are its variables;
            // one complaint about the formula is enough.
            if (t.get("formula") != nullptr && !formula) continue;
            if (formula && formula->uses(key.str())) {
                if (auto range = get_int_pair(node, key.str(), -1'000'000, 1'000'000)) {
                    variables.push_back({std::string(key.str()), range->first, range->second});
                } else {
                    formula_ok = false;
                }
                continue;
            }
            problem(key.source().begin.line != 0 ? key.source() : node.source(),
                    fmt::format("unknown key \"{}\" in [[register]]{}", key.str(),
                                formula ? " (not a variable of the formula)" : ""));
        }

        if (auto table = get_string(t, "table")) {
            if (kStandardTables.count(*table) == 0 && function_tables_.count(*table) == 0) {
                problem(*t.get("table"),
                        fmt::format("unknown table \"{}\" (holding, input, coil, discrete, or the "
                                    "table of a [[function]] defined above)",
                                    *table));
            }
            r.table = *table;
        }

        const toml::node* name_node = t.get("name");
        const auto name = get_string(t, "name");
        if (name) {
            r.name = *name;
        } else if (name_node == nullptr) {
            problem(t, "[[register]] needs a name");
        }

        if (auto type = get_string(t, "type")) {
            if (auto vt = value_type_named(*type)) {
                r.type = *vt;
            } else {
                problem(*t.get("type"),
                        fmt::format("unknown type \"{}\" ({})", *type, value_type_names()));
                sized = false;
            }
        } else if (t.get("type") != nullptr) {
            sized = false;
        }
        if (is_multi_register(r.type)) r.length = registers_of(r.type);
        if (auto order = get_string(t, "word_order")) {
            if (!is_multi_register(r.type)) {
                problem(*t.get("word_order"),
                        "word_order is only for u32, i32, f32, u64, i64 and f64");
            } else if (auto named = word_order_named(*order)) {
                r.word_order = *named;
            } else {
                problem(*t.get("word_order"),
                        fmt::format("unknown word_order \"{}\" ({})", *order, word_order_names()));
            }
        }
        if (auto length = get_integer(t, "length", 1, 125)) {
            if (r.type != ValueType::string) {
                problem(*t.get("length"), "length is only for strings");
            } else {
                r.length = static_cast<std::uint16_t>(*length);
            }
        } else if (r.type == ValueType::string) {
            if (t.get("length") == nullptr) {
                problem(t, fmt::format("string register \"{}\" needs a length", r.name));
            }
            sized = false;
        }
        if (is_bit_table(r.table)) {
            if (r.type != ValueType::u16 && r.type != ValueType::enumeration) {
                problem(*t.get("type"),
                        "coils and discrete inputs are single bits: type u16 "
                        "or enum");
            }
        }

        const toml::node* scale = t.get("scale");
        const toml::node* decimals = t.get("decimals");
        if (scale != nullptr && decimals != nullptr) {
            problem(*decimals, "give scale or decimals, not both");
        } else if (scale != nullptr) {
            if (auto s = get_number(*scale, "scale")) {
                if (*s == 0.0) {
                    problem(*scale, "scale must not be 0");
                } else {
                    r.scale = *s;
                }
            }
        } else if (auto d = get_integer(t, "decimals", 0, 9)) {
            r.decimals = static_cast<int>(*d);
            r.scale = scale_for_decimals(r.decimals);
        }
        r.unit = get_string(t, "unit").value_or("");
        r.description = get_string(t, "description").value_or("");
        if (auto access = get_string(t, "access")) {
            if (*access == "R") {
                r.access = Access::read;
            } else if (*access == "W") {
                r.access = Access::write;
            } else if (*access == "RW") {
                r.access = Access::read_write;
            } else {
                problem(*t.get("access"),
                        fmt::format("access \"{}\" must be \"R\", \"W\" or \"RW\"", *access));
            }
        }
        if (const toml::node* range = t.get("range")) {
            const toml::array* a = range->as_array();
            std::optional<double> lo;
            std::optional<double> hi;
            if (a != nullptr && a->size() == 2) {
                lo = get_number((*a)[0], "range");
                hi = get_number((*a)[1], "range");
            }
            if (!lo || !hi || *lo > *hi) {
                problem(*range, "range must be [min, max] with min <= max");
            } else {
                r.min = lo;
                r.max = hi;
            }
        }
        if (const toml::node* values = t.get("values")) {
            if (r.type != ValueType::enumeration) {
                problem(*values, "values is only for type enum");
            } else {
                r.labels = read_labels(*values, "values", 0xFFFF);
            }
        } else if (r.type == ValueType::enumeration) {
            problem(t, fmt::format("enum register \"{}\" needs values", r.name));
        }
        if (const toml::node* bits = t.get("bits")) {
            if (r.type != ValueType::bits) {
                problem(*bits, "bits is only for type bits");
            } else {
                r.labels = read_labels(*bits, "bits", 15);
            }
        }
        if (const toml::node* writes = t.get("writes")) {
            r.writes = read_labels(*writes, "writes", 0xFFFF);
        }
        if (const toml::node* ha = t.get("home_assistant")) read_home_assistant(*ha, r);

        const toml::node* address = t.get("address");
        if (address != nullptr && t.get("formula") != nullptr) {
            problem(*address, "give address or formula, not both");
            return;
        }
        if (address != nullptr) {
            if (name && !good_name(r.name)) {
                problem(*name_node,
                        fmt::format("name \"{}\" must be letters, digits, _ . -", r.name));
            }
            if (auto a = get_integer(t, "address", 0, 65535)) {
                r.address = static_cast<std::uint16_t>(*a);
                add(std::move(r), sized);
            }
            return;
        }
        if (t.get("formula") == nullptr) {
            problem(t, fmt::format("register \"{}\" needs an address or a formula", r.name));
            return;
        }
        // A formula that cannot be read was reported; a name that is not there cannot be
        // expanded.
        if (formula && formula_ok && name) expand_formula(*formula, variables, r, sized, t);
    }

    void add(Register r, bool sized) {
        (sized ? profile_.registers : unsized_).push_back(std::move(r));
    }

    // One register per combination of the variables' values.
    void expand_formula(const Formula& formula, const std::vector<FormulaVariable>& variables,
                        const Register& pattern, bool sized, const toml::table& t) {
        const toml::node& formula_node = *t.get("formula");
        const std::size_t problems_before = problems_.size();
        for (const std::string& used : formula.variables()) {
            const bool given =
                std::any_of(variables.begin(), variables.end(),
                            [&](const FormulaVariable& v) { return v.name == used; });
            if (!given) {
                problem(formula_node, fmt::format("formula variable \"{}\" needs a range: "
                                                  "{} = [first, last]",
                                                  used, used));
            }
        }
        for (const FormulaVariable& v : variables) {
            if (pattern.name.find("{" + v.name + "}") == std::string::npos) {
                problem(t.get("name") != nullptr ? t.get("name")->source() : t.source(),
                        fmt::format("name \"{}\" must contain {{{}}}: each register of a "
                                    "formula needs its own name",
                                    pattern.name, v.name));
            }
        }
        std::size_t count = 1;
        for (const FormulaVariable& v : variables) {
            count *= static_cast<std::size_t>(v.last - v.first + 1);
            if (count > kMaxFormulaRegisters) break;
        }
        if (count > kMaxFormulaRegisters) {
            problem(formula_node, fmt::format("the formula's ranges give more than {} registers",
                                              kMaxFormulaRegisters));
            return;
        }
        if (problems_.size() != problems_before) return;

        std::map<std::string, std::int64_t, std::less<>> env;
        for (const FormulaVariable& v : variables) env[v.name] = v.first;
        for (std::size_t n = 0; n < count; ++n) {
            auto value = formula.evaluate(env);
            std::string name = pattern.name;
            for (const auto& [var, val] : env) {
                const std::string placeholder = "{" + var + "}";
                for (auto at = name.find(placeholder); at != std::string::npos;
                     at = name.find(placeholder)) {
                    name.replace(at, placeholder.size(), std::to_string(val));
                }
            }
            if (!value) {
                problem(formula_node,
                        fmt::format("formula: {} for {}", value.error().message, name));
                return;
            }
            if (*value < 0 || *value > 65535) {
                problem(
                    formula_node,
                    fmt::format("formula gives address {} for {}, outside 0-65535", *value, name));
                return;
            }
            if (!good_name(name)) {
                problem(t.get("name")->source(),
                        fmt::format("name \"{}\" must be letters, digits, _ . -", name));
                return;
            }
            Register r = pattern;
            r.address = static_cast<std::uint16_t>(*value);
            r.name = std::move(name);
            add(std::move(r), sized);
            // Next combination: the last variable counts fastest.
            for (auto v = variables.rbegin(); v != variables.rend(); ++v) {
                if (++env[v->name] <= v->last) break;
                env[v->name] = v->first;
            }
        }
    }

    void check_registers() {
        auto& regs = profile_.registers;
        std::stable_sort(regs.begin(), regs.end(), [](const Register& a, const Register& b) {
            return std::tie(a.table, a.address) < std::tie(b.table, b.address);
        });
        auto end_address = [](const Register& r) {
            return static_cast<unsigned>(r.address) + r.length;
        };
        // Of the registers before this one in its table, the one that reaches furthest: a
        // register overlaps an earlier one exactly when it starts before that one's end
        // (a long string may cover several registers after it, not only the next).
        const Register* reach = nullptr;
        for (const Register& r : regs) {
            if (reach != nullptr && reach->table != r.table) reach = nullptr;
            if (end_address(r) - 1 > 65535) {
                problem(r.pos, fmt::format("register \"{}\" at 0x{:04X} takes {} registers and "
                                           "runs past address 0xFFFF",
                                           r.name, r.address, r.length));
            }
            if (reach != nullptr && end_address(*reach) > r.address) {
                // Report at whichever of the two stands later in the file.
                const bool r_later = std::tie(r.pos.line, r.pos.column) >=
                                     std::tie(reach->pos.line, reach->pos.column);
                const Register& later = r_later ? r : *reach;
                const Register& first = r_later ? *reach : r;
                problem(
                    later.pos,
                    fmt::format("register \"{}\" (0x{:04X}) overlaps \"{}\" (0x{:04X}, {} "
                                "register{}, line {}) in table {}",
                                later.name, later.address, first.name, first.address, first.length,
                                first.length == 1 ? "" : "s", first.pos.line, r.table));
            }
            if (reach == nullptr || end_address(r) > end_address(*reach)) reach = &r;
        }
        std::map<std::string_view, const Register*> names;
        auto check_name = [&](const Register& r) {
            if (r.name.empty()) return;  // reported as missing
            auto [it, fresh] = names.emplace(r.name, &r);
            if (!fresh) {
                const Register& other = *it->second;
                const bool r_later = std::tie(r.pos.line, r.pos.column) >=
                                     std::tie(other.pos.line, other.pos.column);
                problem(r_later ? r.pos : other.pos,
                        fmt::format("duplicate register name \"{}\" (also at line {})", r.name,
                                    r_later ? other.pos.line : r.pos.line));
            }
        };
        for (const Register& r : regs) check_name(r);
        for (const Register& r : unsized_) check_name(r);
    }
};

}  // namespace

ProfileLoad load_profile_text(const std::string& text, const std::string& file_name) {
    return Loader(file_name).load(text);
}

ProfileLoad load_profile_file(const std::string& path) {
    auto text = read_text_file(path);
    if (!text) {
        ProfileLoad load;
        load.problems.push_back({path, 0, 0, text.error().message});
        return load;
    }
    return load_profile_text(*text, path);
}

}  // namespace rtuscope
