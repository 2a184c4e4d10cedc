#include "stop_signals.hpp"

#include <csignal>

namespace rtuscope::cli {

std::atomic<bool> g_stop{false};

namespace {

std::atomic<int> g_signal{0};

extern "C" void on_stop_signal(int signal) {
    g_signal.store(signal);
    g_stop.store(true);
    std::signal(signal, SIG_DFL);  // the second one is not asked twice
}

}  // namespace

void install_stop_handlers() {
    struct sigaction action {};
    action.sa_handler = on_stop_signal;
    sigemptyset(&action.sa_mask);
    action.sa_flags = 0;
    sigaction(SIGINT, &action, nullptr);
    sigaction(SIGTERM, &action, nullptr);
}

int stop_signal() {
    return g_signal.load();
}

}  // namespace rtuscope::cli
