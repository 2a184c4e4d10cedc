#include "util/terminal.hpp"

#include <sys/ioctl.h>
#include <unistd.h>

#include <atomic>
#include <clocale>
#include <csignal>
#include <cstdlib>
#include <cwchar>

namespace rtuscope {
namespace {

constexpr std::string_view kEllipsis = "…";
constexpr std::string_view kColourReset = "\x1b[0m";

// The length of the escape sequence at text[i] (ESC [ ... final byte), 0 if none starts
// there.
std::size_t escape_length(std::string_view text, std::size_t i) {
    if (text[i] != '\x1b' || i + 1 >= text.size() || text[i + 1] != '[') return 0;
    std::size_t end = i + 2;
    while (end < text.size() && (text[end] < 0x40 || text[end] > 0x7E)) ++end;
    return end < text.size() ? end + 1 - i : text.size() - i;
}

// The UTF-8 character at text[i]: its length in bytes and its columns.
struct Character {
    std::size_t bytes;
    std::size_t columns;
};

bool can_measure_wide() {
    // wcwidth knows the width of non-ASCII characters only in a UTF-8 locale; LC_CTYPE
    // alone changes nothing else rtuscope prints.
    static const bool ok = [] {
        const char* set = std::setlocale(LC_CTYPE, "C.UTF-8");
        return set != nullptr;
    }();
    return ok;
}

Character character_at(std::string_view text, std::size_t i) {
    const auto lead = static_cast<unsigned char>(text[i]);
    if (lead < 0x80) return {1, lead < 0x20 ? 0U : 1U};
    const std::size_t n = lead >= 0xF0 ? 4 : lead >= 0xE0 ? 3 : lead >= 0xC0 ? 2 : 1;
    if (n == 1 || i + n > text.size()) return {1, 1};
    char32_t code = lead & (0x7FU >> n);
    for (std::size_t k = 1; k < n; ++k) {
        const auto next = static_cast<unsigned char>(text[i + k]);
        if ((next & 0xC0U) != 0x80U) return {1, 1};
        code = (code << 6U) | (next & 0x3FU);
    }
    if (!can_measure_wide()) return {n, 1};
    const int columns = ::wcwidth(static_cast<wchar_t>(code));
    return {n, columns < 0 ? 1U : static_cast<std::size_t>(columns)};
}

std::atomic<unsigned long> g_resizes{1};  // NOLINT(google-runtime-int)

extern "C" void on_resize(int /*signal*/) { g_resizes.fetch_add(1, std::memory_order_relaxed); }

}  // namespace

std::size_t display_width(std::string_view text) {
    std::size_t columns = 0;
    for (std::size_t i = 0; i < text.size();) {
        if (const std::size_t escape = escape_length(text, i); escape != 0) {
            i += escape;
            continue;
        }
        const Character c = character_at(text, i);
        columns += c.columns;
        i += c.bytes;
    }
    return columns;
}

void cut_to_width(std::string& text, std::size_t width, std::size_t from) {
    std::string_view line = std::string_view(text).substr(from);
    if (width == 0 || display_width(line) <= width) return;
    std::size_t columns = 0;
    bool coloured = false;
    std::size_t i = 0;
    while (i < line.size()) {
        if (const std::size_t escape = escape_length(line, i); escape != 0) {
            coloured = line.substr(i, escape) != kColourReset;
            i += escape;
            continue;
        }
        const Character c = character_at(line, i);
        if (columns + c.columns > width - 1) break;  // one column left for the ellipsis
        columns += c.columns;
        i += c.bytes;
    }
    text.resize(from + i);
    text += kEllipsis;
    if (coloured) text += kColourReset;
}

TerminalWidth::TerminalWidth(int fd) : fd_(fd) {
    static const bool watching = [] {
        struct sigaction action {};
        action.sa_handler = on_resize;
        sigemptyset(&action.sa_mask);
        action.sa_flags = SA_RESTART;
        return sigaction(SIGWINCH, &action, nullptr) == 0;
    }();
    (void)watching;
}

std::size_t TerminalWidth::columns() {
    const auto resizes = g_resizes.load(std::memory_order_relaxed);
    if (resizes == seen_resizes_) return columns_;
    seen_resizes_ = resizes;
    winsize size{};
    if (isatty(fd_) && ioctl(fd_, TIOCGWINSZ, &size) == 0 && size.ws_col != 0) {
        columns_ = size.ws_col;
    } else if (const char* env = std::getenv("COLUMNS"); env != nullptr) {
        columns_ = std::strtoul(env, nullptr, 10);
    } else {
        columns_ = 0;
    }
    return columns_;
}

}  // namespace rtuscope
