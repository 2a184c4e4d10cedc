// Ctrl-C (SIGINT), SIGTERM and SIGHUP stop a run cleanly: the pipeline stops at a record boundary,
// every output is flushed and closed, and the summary is printed. A second signal of the
// same kind ends the process at once, as it would without rtuscope's handler.
#pragma once

#include <atomic>

namespace rtuscope::cli {

// Set by the first SIGINT, SIGTERM or SIGHUP.
extern std::atomic<bool> g_stop;
// Set by SIGUSR1: a recording starts its next file (tcpdump users rotate logs so).
extern std::atomic<bool> g_rotate;
// Set by SIGUSR1 too: a --report page is written now (the run goes on). Each flag is
// cleared by its own reader, so one signal both rotates and writes the page.
extern std::atomic<bool> g_report;

// Installs the handlers. Blocking reads are interrupted (no SA_RESTART), so that a run
// waiting on an idle pipe or port stops too.
void install_stop_handlers();

// The signal that stopped the run, 0 while none has.
int stop_signal();

}  // namespace rtuscope::cli
