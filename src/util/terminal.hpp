// What a terminal shows: how many columns text takes, a line cut to fit, the terminal's
// width as it changes.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace rtuscope {

// Columns `text` takes on a terminal: colour escape sequences take none, a character of
// an East Asian script two (wcwidth), a byte that is no UTF-8 one.
std::size_t display_width(std::string_view text);

// Cuts the line that starts at `from` in `text` (running to its end, no newline) to at
// most `width` columns, its last one "…" when anything was cut; a colour the cut left
// open is closed. Width 0 cuts nothing.
void cut_to_width(std::string& text, std::size_t width, std::size_t from = 0);

// The width of the terminal on `fd`, read again after each SIGWINCH (a resized window);
// COLUMNS when the terminal does not say (or `fd` is no terminal), 0 when neither does.
class TerminalWidth {
  public:
    explicit TerminalWidth(int fd);
    std::size_t columns();

  private:
    int fd_;
    std::size_t columns_ = 0;
    unsigned long seen_resizes_ = 0;  // NOLINT(google-runtime-int): sig_atomic_t's peer
};

}  // namespace rtuscope
