// Result<T>: operational failures (open, read, parse of a file or option) as values.
// GCC 12 has std::expected only under C++23, so this is the small subset we need.
#pragma once

#include <string>
#include <utility>
#include <variant>

namespace rtuscope {

// One clear line for the user; file/line/column when the error points into a file.
struct Error {
    Error() = default;
    explicit Error(std::string message_, std::string file_ = {}, int line_ = 0, int column_ = 0)
        : message(std::move(message_)), file(std::move(file_)), line(line_), column(column_) {}

    std::string message;
    std::string file;
    int line = 0;    // 1-based, 0 = none
    int column = 0;  // 1-based, 0 = none

    // "FILE:LINE:COL: message", dropping the parts that are not known.
    [[nodiscard]] std::string to_string() const;
};

struct Unit {};

template <class T>
class [[nodiscard]] Result {
  public:
    Result(T value) : v_(std::move(value)) {}      // NOLINT(google-explicit-constructor)
    Result(Error error) : v_(std::move(error)) {}  // NOLINT(google-explicit-constructor)

    [[nodiscard]] bool ok() const { return v_.index() == 0; }
    explicit operator bool() const { return ok(); }
    T& value() { return std::get<0>(v_); }
    const T& value() const { return std::get<0>(v_); }
    T& operator*() { return value(); }
    const T& operator*() const { return value(); }
    T* operator->() { return &value(); }
    const T* operator->() const { return &value(); }
    const Error& error() const { return std::get<1>(v_); }

  private:
    std::variant<T, Error> v_;
};

using Status = Result<Unit>;

inline Status ok_status() {
    return Unit{};
}

}  // namespace rtuscope
