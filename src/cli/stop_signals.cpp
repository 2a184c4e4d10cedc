#include "stop_signals.hpp"

#include <csignal>

namespace rtuscope::cli {

std::atomic<bool> g_stop{false};
std::atomic<bool> g_rotate{false};
std::atomic<bool> g_report{false};

namespace {

std::atomic<int> g_signal{0};

extern "C" void on_stop_signal(int signal) {
    g_signal.store(signal);
    g_stop.store(true);
    std::signal(signal, SIG_DFL);  // the second one is not asked twice
}

extern "C" void on_rotate_signal(int /*signal*/) {
    g_rotate.store(true);
    g_report.store(true);
}

}  // namespace

void install_stop_handlers() {
    struct sigaction action {};
    action.sa_handler = on_stop_signal;
    sigemptyset(&action.sa_mask);
    action.sa_flags = 0;
    sigaction(SIGINT, &action, nullptr);
    sigaction(SIGTERM, &action, nullptr);
    // A terminal closed under a run (an ssh session dropped) ends it as SIGTERM does,
    // with the outputs closed, rather than cutting them.
    sigaction(SIGHUP, &action, nullptr);
    struct sigaction rotate {};
    rotate.sa_handler = on_rotate_signal;
    sigemptyset(&rotate.sa_mask);
    rotate.sa_flags = SA_RESTART;
    sigaction(SIGUSR1, &rotate, nullptr);
}

int stop_signal() {
    return g_signal.load();
}

}  // namespace rtuscope::cli
