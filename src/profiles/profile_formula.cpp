// A recursive-descent parser for register address formulas (see profile_formula.hpp).
#include "profiles/profile_formula.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>

namespace rtuscope {

struct Formula::Node {
    enum class Kind : std::uint8_t {
        number,
        variable,
        add,
        sub,
        mul,
        div,
        negate
    } kind = Kind::number;
    std::int64_t number = 0;
    std::string variable;
    std::unique_ptr<Node> left;
    std::unique_ptr<Node> right;
};

namespace {

using Node = Formula::Node;

// Literals above this are surely a mistake in an address formula, and keeping them small
// keeps the arithmetic far from overflow.
constexpr std::int64_t kMaxLiteral = 1'000'000'000;

class Parser {
  public:
    explicit Parser(std::string_view text) : text_(text) {}

    Result<std::unique_ptr<Node>> parse() {
        auto node = sum();
        if (!error_.empty()) return Error{error_};
        skip_space();
        if (pos_ != text_.size()) return Error{unexpected()};
        return node;
    }

  private:
    std::string_view text_;
    std::size_t pos_ = 0;
    std::string error_;
    int depth_ = 0;  // nesting, bounded so that a hostile formula cannot exhaust the stack

    void skip_space() {
        while (pos_ < text_.size() && text_[pos_] == ' ') ++pos_;
    }
    std::string unexpected() const {
        if (pos_ >= text_.size()) return "the formula ends too early";
        return fmt::format("unexpected '{}' at character {}", text_[pos_], pos_ + 1);
    }
    std::unique_ptr<Node> fail(std::string message) {
        if (error_.empty()) error_ = std::move(message);
        return nullptr;
    }
    static std::unique_ptr<Node> binary(Node::Kind kind, std::unique_ptr<Node> l,
                                        std::unique_ptr<Node> r) {
        auto node = std::make_unique<Node>();
        node->kind = kind;
        node->left = std::move(l);
        node->right = std::move(r);
        return node;
    }

    std::unique_ptr<Node> sum() {
        auto left = product();
        while (error_.empty()) {
            skip_space();
            if (pos_ >= text_.size() || (text_[pos_] != '+' && text_[pos_] != '-')) break;
            const auto kind = text_[pos_++] == '+' ? Node::Kind::add : Node::Kind::sub;
            left = binary(kind, std::move(left), product());
        }
        return left;
    }
    std::unique_ptr<Node> product() {
        auto left = factor();
        while (error_.empty()) {
            skip_space();
            if (pos_ >= text_.size() || (text_[pos_] != '*' && text_[pos_] != '/')) break;
            const auto kind = text_[pos_++] == '*' ? Node::Kind::mul : Node::Kind::div;
            left = binary(kind, std::move(left), factor());
        }
        return left;
    }
    std::unique_ptr<Node> factor() {
        struct Nesting {
            int& depth;
            explicit Nesting(int& d) : depth(++d) {}
            ~Nesting() { --depth; }
        } nesting(depth_);
        if (depth_ > 64) return fail("the formula nests too deeply");
        skip_space();
        if (pos_ >= text_.size()) return fail(unexpected());
        const char c = text_[pos_];
        if (c == '(') {
            ++pos_;
            auto inner = sum();
            skip_space();
            if (!error_.empty()) return nullptr;
            if (pos_ >= text_.size() || text_[pos_] != ')') {
                return fail(fmt::format("expected ')' at character {}", pos_ + 1));
            }
            ++pos_;
            return inner;
        }
        if (c == '-') {
            ++pos_;
            auto node = std::make_unique<Node>();
            node->kind = Node::Kind::negate;
            node->left = factor();
            return node;
        }
        if (std::isdigit(static_cast<unsigned char>(c)) != 0) {
            auto node = std::make_unique<Node>();
            node->kind = Node::Kind::number;
            const std::size_t start = pos_;
            while (pos_ < text_.size() && std::isdigit(static_cast<unsigned char>(text_[pos_]))) {
                node->number = node->number * 10 + (text_[pos_++] - '0');
                if (node->number > kMaxLiteral) {
                    return fail(fmt::format("number at character {} is too large", start + 1));
                }
            }
            return node;
        }
        if (std::isalpha(static_cast<unsigned char>(c)) != 0 || c == '_') {
            auto node = std::make_unique<Node>();
            node->kind = Node::Kind::variable;
            while (pos_ < text_.size() &&
                   (std::isalnum(static_cast<unsigned char>(text_[pos_])) || text_[pos_] == '_')) {
                node->variable += text_[pos_++];
            }
            return node;
        }
        return fail(unexpected());
    }
};

void collect_variables(const Node& node, std::vector<std::string>& out) {
    if (node.kind == Node::Kind::variable) out.push_back(node.variable);
    if (node.left) collect_variables(*node.left, out);
    if (node.right) collect_variables(*node.right, out);
}

Result<std::int64_t> eval(const Node& node,
                          const std::map<std::string, std::int64_t, std::less<>>& values) {
    switch (node.kind) {
        case Node::Kind::number:
            return node.number;
        case Node::Kind::variable: {
            auto it = values.find(node.variable);
            if (it == values.end()) return Error{fmt::format("no value for {}", node.variable)};
            return it->second;
        }
        case Node::Kind::negate: {
            auto v = eval(*node.left, values);
            if (!v) return v;
            return -*v;
        }
        default:
            break;
    }
    auto l = eval(*node.left, values);
    if (!l) return l;
    auto r = eval(*node.right, values);
    if (!r) return r;
    std::int64_t out = 0;
    bool overflow = false;
    switch (node.kind) {
        case Node::Kind::add:
            overflow = __builtin_add_overflow(*l, *r, &out);
            break;
        case Node::Kind::sub:
            overflow = __builtin_sub_overflow(*l, *r, &out);
            break;
        case Node::Kind::mul:
            overflow = __builtin_mul_overflow(*l, *r, &out);
            break;
        case Node::Kind::div:
            if (*r == 0) return Error{"division by zero"};
            out = *l / *r;
            break;
        default:
            break;
    }
    if (overflow) return Error{"the value overflows"};
    return out;
}

}  // namespace

Formula::Formula() = default;
Formula::~Formula() = default;
Formula::Formula(Formula&&) noexcept = default;
Formula& Formula::operator=(Formula&&) noexcept = default;

Result<std::int64_t> Formula::evaluate(
    const std::map<std::string, std::int64_t, std::less<>>& values) const {
    if (!root_) return Error{"empty formula"};
    return eval(*root_, values);
}

bool Formula::uses(std::string_view name) const {
    return std::binary_search(variables_.begin(), variables_.end(), name);
}

Result<Formula> parse_formula(std::string_view text) {
    Parser parser(text);
    auto root = parser.parse();
    if (!root) return root.error();
    Formula formula;
    formula.root_ = std::move(*root);
    collect_variables(*formula.root_, formula.variables_);
    std::sort(formula.variables_.begin(), formula.variables_.end());
    formula.variables_.erase(std::unique(formula.variables_.begin(), formula.variables_.end()),
                             formula.variables_.end());
    return formula;
}

}  // namespace rtuscope
