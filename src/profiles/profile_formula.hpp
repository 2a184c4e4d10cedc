// Address formulas of profile registers: "(channel-1)*100 + (sensor-1)*2". Integers,
// + - * /, parentheses and named variables; nothing else, so a formula in a user's file
// can never do more than compute a number.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "util/result.hpp"

namespace rtuscope {

struct FormulaVariable {
    std::string name;
    std::int64_t first = 0;
    std::int64_t last = 0;
};

class Formula {
  public:
    struct Node;  // the parsed expression tree

    Formula();
    ~Formula();
    Formula(Formula&&) noexcept;
    Formula& operator=(Formula&&) noexcept;

    // The value for these variable values; an error on division by zero, on overflow, or
    // when a variable has no value.
    [[nodiscard]] Result<std::int64_t> evaluate(
        const std::map<std::string, std::int64_t, std::less<>>& values) const;
    // The variables the formula uses, sorted, each once.
    [[nodiscard]] const std::vector<std::string>& variables() const { return variables_; }
    [[nodiscard]] bool uses(std::string_view name) const;

  private:
    friend Result<Formula> parse_formula(std::string_view text);
    std::unique_ptr<Node> root_;
    std::vector<std::string> variables_;
};

// A syntax error names the character position: "expected ')' at character 12".
Result<Formula> parse_formula(std::string_view text);

}  // namespace rtuscope
