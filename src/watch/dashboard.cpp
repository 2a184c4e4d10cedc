// The full-screen dashboard: ncurses draws, the state (state/) and its text (state_text)
// say what. Layout, top to bottom: the bus line; the slaves, one a line, the selected one
// marked; the selected slave's registers, scrolled; the latest anomalies; a status line.
#include <curses.h>
#include <fmt/format.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <algorithm>
#include <clocale>
#include <cstdlib>
#include <ctime>

#include "state/state_text.hpp"
#include "util/terminal.hpp"
#include "watch/watch.hpp"

namespace rtuscope {
namespace {

Nanos steady_now() { return clock_ns(CLOCK_MONOTONIC); }

constexpr Nanos kDrawEvery = 100'000'000;  // at most 10 frames a second
constexpr Nanos kKeysEvery = 20'000'000;   // keys are read this often, drawn or not
constexpr std::size_t kAnomalyLines = 3;

enum Pair : short { kHeading = 1, kHealthy, kDegraded, kFailing, kChanged, kWritten };

const char* const kHelp[] = {
    "rtuscope watch: keys",
    "",
    "  Up, Down        select a slave (in its registers: scroll them)",
    "  PgUp, PgDn      scroll the registers",
    "  Enter           open the selected slave's registers; Left or Esc goes back",
    "  /               filter registers by name (Enter applies, Esc clears)",
    "  s               sort registers: address, name, last change",
    "  p               pause the display (the state keeps updating)",
    "  r               reset min/max, counters and windows",
    "  f               freeze a snapshot to a text file",
    "  ?               this help; any key closes it",
    "  q               quit",
};

class Dashboard final : public Display {
  public:
    explicit Dashboard(const DashboardOptions& options) : options_(options) {
        std::setlocale(LC_ALL, "");
        initscr();
        cbreak();
        noecho();
        keypad(stdscr, TRUE);
        nodelay(stdscr, TRUE);
        curs_set(0);
        color_ = options.color && std::getenv("NO_COLOR") == nullptr && has_colors();
        if (color_) {
            start_color();
            use_default_colors();
            init_pair(kHeading, COLOR_BLACK, COLOR_CYAN);
            init_pair(kHealthy, COLOR_GREEN, -1);
            init_pair(kDegraded, COLOR_YELLOW, -1);
            init_pair(kFailing, COLOR_RED, -1);
            init_pair(kChanged, COLOR_CYAN, -1);
            init_pair(kWritten, COLOR_MAGENTA, -1);
        }
    }
    ~Dashboard() override {
        if (isendwin() == FALSE) endwin();
    }
    Dashboard(const Dashboard&) = delete;
    Dashboard& operator=(const Dashboard&) = delete;

    void show(BusState& state, Nanos now) override {
        const Nanos t = steady_now();
        if (t - last_keys_ >= kKeysEvery) {
            last_keys_ = t;
            read_keys(state, now);
        }
        if (t - last_draw_ < kDrawEvery || (paused_ && !dirty_)) return;
        draw(state, now);
    }

    void finish(SharedState& shared, Nanos now) override {
        ended_ = true;
        BusState& state = shared.state;
        std::unique_lock lock(shared.mutex);
        state.refresh();
        draw(state, now);
        // A replay that reached its end stays on screen until `q`; a stop (q, a signal,
        // --seconds) ends at once.
        const bool stopped = quit_ || (options_.quit != nullptr && options_.quit->load());
        if (options_.replay && !stopped) {
            while (!quit_ && (options_.quit == nullptr || !options_.quit->load())) {
                // Up to 500 ms for a key, without the state held; then the keys at once.
                lock.unlock();
                timeout(500);
                const int key = getch();
                nodelay(stdscr, TRUE);
                lock.lock();
                if (key != ERR) ungetch(key);
                read_keys(state, now);
                draw(state, now);
            }
        }
        // The terminal back as it was, before the run's summary is printed on it.
        endwin();
    }

  private:
    void read_keys(BusState& state, Nanos now) {
        for (int key = getch(); key != ERR; key = getch()) {
            dirty_ = true;
            if (help_) {
                help_ = false;
                continue;
            }
            if (filtering_) {
                edit_filter(key);
                continue;
            }
            const std::size_t slaves = state.slaves().size();
            switch (key) {
                case KEY_RESIZE:  // ncurses has the new size: the whole screen is redrawn
                    clear();
                    break;
                case 'q':
                case 'Q':
                    quit_ = true;
                    if (options_.quit != nullptr) options_.quit->store(true);
                    return;
                case KEY_UP:
                    if (opened_) {
                        if (scroll_ > 0) --scroll_;
                    } else if (selected_ > 0) {
                        --selected_;
                        scroll_ = 0;
                    }
                    break;
                case KEY_DOWN:
                    if (opened_) {
                        ++scroll_;
                    } else if (selected_ + 1 < slaves) {
                        ++selected_;
                        scroll_ = 0;
                    }
                    break;
                case KEY_LEFT:
                case KEY_BACKSPACE:
                case 27:  // Esc: back to the slaves
                    opened_ = false;
                    break;
                case KEY_NPAGE:
                    scroll_ += page_;
                    break;
                case KEY_PPAGE:
                    scroll_ = scroll_ > page_ ? scroll_ - page_ : 0;
                    break;
                case '\n':
                case KEY_ENTER:
                    opened_ = true;
                    scroll_ = 0;
                    break;
                case '/':
                    filtering_ = true;
                    filter_edit_ = view_.register_filter;
                    break;
                case 's':
                    view_.sort = view_.sort == StateView::Sort::address ? StateView::Sort::name
                                 : view_.sort == StateView::Sort::name
                                     ? StateView::Sort::last_change
                                     : StateView::Sort::address;
                    break;
                case 'p':
                    paused_ = !paused_;
                    break;
                case 'r':
                    state.reset();
                    message_ = "counters, min/max and windows reset";
                    break;
                case 'f':
                    freeze(state, now);
                    break;
                case '?':
                    help_ = true;
                    break;
                default:
                    break;
            }
        }
    }

    void edit_filter(int key) {
        if (key == '\n' || key == KEY_ENTER) {
            view_.register_filter = filter_edit_;
            filtering_ = false;
            scroll_ = 0;
        } else if (key == 27) {  // Esc
            view_.register_filter.clear();
            filtering_ = false;
        } else if (key == KEY_BACKSPACE || key == 127 || key == 8) {
            if (!filter_edit_.empty()) filter_edit_.pop_back();
        } else if (key >= 32 && key < 127) {
            filter_edit_ += static_cast<char>(key);
        }
    }

    void freeze(BusState& state, Nanos now) {
        state.refresh();
        StateView view = view_;
        view.now = now;
        const std::time_t t = std::time(nullptr);
        std::tm tm{};
        localtime_r(&t, &tm);
        char name[64];
        std::strftime(name, sizeof name, "rtuscope-snapshot-%Y%m%d-%H%M%S.txt", &tm);
        std::FILE* f = std::fopen(name, "w");
        if (f == nullptr) {
            message_ = fmt::format("cannot write {}", name);
            return;
        }
        const std::string text = state_text(state, view);
        const bool written = std::fputs(text.c_str(), f) >= 0;
        message_ = std::fclose(f) == 0 && written ? fmt::format("snapshot written to {}", name)
                                                  : fmt::format("cannot write {}", name);
    }

    void line(int row, std::string text, LineStyle style, bool selected = false) {
        if (row >= LINES) return;
        cut_to_width(text, static_cast<std::size_t>(COLS));
        attr_t attrs = selected ? A_REVERSE : A_NORMAL;
        short pair = 0;
        switch (style) {
            case LineStyle::heading:
                attrs |= A_BOLD;
                pair = kHeading;
                break;
            case LineStyle::healthy:
                pair = kHealthy;
                break;
            case LineStyle::degraded:
                pair = kDegraded;
                break;
            case LineStyle::failing:
                pair = kFailing;
                attrs |= A_BOLD;
                break;
            case LineStyle::changed:
                pair = kChanged;
                attrs |= A_BOLD;
                break;
            case LineStyle::written:
                pair = kWritten;
                break;
            case LineStyle::plain:
                break;
        }
        if (!color_) pair = 0;
        if (!color_ && style == LineStyle::changed) attrs |= A_BOLD;
        attr_set(attrs, pair, nullptr);
        mvaddstr(row, 0, text.c_str());
        clrtoeol();
        attr_set(A_NORMAL, 0, nullptr);
    }

    // The terminal's size, asked rather than signalled: ncurses hears SIGWINCH only when
    // no handler was there before it, and the process may have one.
    static void follow_resize() {
        struct winsize size {};
        if (ioctl(STDOUT_FILENO, TIOCGWINSZ, &size) != 0 || size.ws_row == 0) return;
        if (is_term_resized(size.ws_row, size.ws_col)) {
            resizeterm(size.ws_row, size.ws_col);
            clear();
        }
    }

    void draw(BusState& state, Nanos now) {
        last_draw_ = steady_now();
        follow_resize();
        dirty_ = false;
        view_.now = now;
        erase();
        if (help_) {
            int row = 0;
            for (const char* h : kHelp) {
                line(row, h, row == 0 ? LineStyle::heading : LineStyle::plain);
                ++row;
            }
            refresh();
            return;
        }
        int row = 0;
        line(row++, bus_line(state, view_), LineStyle::heading);
        if (const std::string status = recording(); !status.empty()) line(row++, status, LineStyle::plain);
        const std::vector<StyledLine> slaves = slave_table(state, view_);
        const std::vector<const SlaveState*> slave_list = state.slaves();
        if (selected_ >= slave_list.size()) selected_ = slave_list.empty() ? 0 : slave_list.size() - 1;
        // The slaves get up to a third of the screen, every one of them when it fits.
        const int footer = static_cast<int>(kAnomalyLines) + 1;
        const int slave_rows = std::max(2, std::min(static_cast<int>(slaves.size()),
                                                    std::max(2, (LINES - 1 - footer) / 2)));
        std::size_t first_slave = 0;
        if (selected_ + 2 > static_cast<std::size_t>(slave_rows)) {
            first_slave = selected_ + 2 - static_cast<std::size_t>(slave_rows);
        }
        line(row++, slaves[0].text, LineStyle::heading);
        for (std::size_t i = first_slave; i + 1 < slaves.size() && row < 1 + slave_rows; ++i) {
            line(row++, slaves[i + 1].text, slaves[i + 1].style, i == selected_);
        }
        if (!slave_list.empty()) {
            const SlaveState& s = *slave_list[selected_];
            const std::vector<const RegisterState*> shown =
                shown_registers(state, s.address, view_);
            ++row;
            line(row++,
                 fmt::format("slave {} ({}): {} registers{}{}", s.address,
                             s.profile != nullptr ? s.profile->name : "no profile",
                             shown.size(),
                             view_.register_filter.empty()
                                 ? ""
                                 : fmt::format(", name contains \"{}\"", view_.register_filter),
                             view_.sort == StateView::Sort::name          ? ", by name"
                             : view_.sort == StateView::Sort::last_change ? ", latest change first"
                                                                          : ""),
                 LineStyle::plain);
            const int room = std::max(1, LINES - footer - row - 1);
            page_ = static_cast<std::size_t>(room);
            const std::size_t count = shown.size();
            if (scroll_ >= count) scroll_ = count > 0 ? count - 1 : 0;
            // Only the rows that fit are formatted: a slave may have thousands.
            const std::size_t visible = std::min(count - scroll_, static_cast<std::size_t>(room));
            const std::vector<StyledLine> registers = register_table(
                state, std::span(shown).subspan(scroll_, visible), view_);
            for (const StyledLine& l : registers) {
                if (row >= LINES - footer) break;
                line(row++, l.text, l.style);
            }
        }
        // Anomalies, newest last, above the status line.
        const std::vector<std::string> anomalies = state.anomalies();
        int arow = LINES - footer;
        const std::size_t shown = std::min(kAnomalyLines, anomalies.size());
        for (std::size_t i = anomalies.size() - shown; i < anomalies.size(); ++i) {
            line(arow++, "! " + anomalies[i], LineStyle::degraded);
        }
        std::string status;
        if (filtering_) {
            status = "filter registers by name: " + filter_edit_ + "_";
        } else if (!message_.empty()) {
            status = message_;
        } else if (ended_) {
            status = "end of input; q quits";
        } else {
            status = fmt::format("{}q quit  ? help  Enter open  / filter  s sort  p pause  r reset  "
                                 "f snapshot",
                                 paused_ ? "[paused]  " : "");
        }
        line(LINES - 1, status, LineStyle::heading);
        refresh();
    }

    DashboardOptions options_;
    bool color_ = false;
    StateView view_;
    std::size_t selected_ = 0;
    std::size_t scroll_ = 0;
    std::size_t page_ = 10;
    bool opened_ = false;
    bool paused_ = false;
    bool help_ = false;
    bool filtering_ = false;
    bool quit_ = false;
    bool ended_ = false;
    bool dirty_ = true;
    std::string filter_edit_;
    std::string message_;
    Nanos last_draw_ = 0;
    Nanos last_keys_ = 0;
};

}  // namespace

std::unique_ptr<Display> make_dashboard(const DashboardOptions& options) {
    return std::make_unique<Dashboard>(options);
}

}  // namespace rtuscope
