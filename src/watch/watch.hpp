// `rtuscope watch`: the bus's state (state/bus_state.hpp) kept up to date from the
// pipeline's records and shown, either full-screen on a terminal (ncurses) or as plain
// text tables every few seconds.
#pragma once

#include <atomic>
#include <cstdio>
#include <functional>
#include <memory>
#include <string>

#include "pipeline.hpp"
#include "state/bus_state.hpp"

namespace rtuscope {

// Shows the state; called for every record and every idle tick, it decides itself when
// to draw. `now`: the records' clock (a replay's capture time, a live run's wall clock).
class Display {
  public:
    virtual ~Display() = default;
    virtual void show(BusState& state, Nanos now) = 0;
    // The input ended (or the run was stopped): the last state. Called without the
    // state's mutex: a replay's last screen may wait for `q` while a scrape reads it.
    virtual void finish(SharedState& shared, Nanos now) = 0;
    // What the run's recording has done ("recording bus-...Z.rtucap, 12 files; 3 trigger
    // events, 2 windows"), shown with the state; called on the pipeline's thread, as
    // show() is.
    void set_recording(std::function<std::string()> status) { recording_ = std::move(status); }

  protected:
    [[nodiscard]] std::string recording() const { return recording_ ? recording_() : std::string(); }

  private:
    std::function<std::string()> recording_;
};

// Tables as text on `out` each time `interval` passes on the records' clock, and at the
// end: for cron, logs and terminals without a type.
std::unique_ptr<Display> make_plain_display(std::FILE* out, Nanos interval);

struct DashboardOptions {
    bool color = true;              // NO_COLOR and --no-color turn it off
    std::atomic<bool>* quit = nullptr;  // set by `q`: the run stops
    bool replay = false;            // the input is a file: at its end, wait for `q`
};
// The full-screen dashboard on the terminal (ncurses); draws at most 10 times a second.
std::unique_ptr<Display> make_dashboard(const DashboardOptions& options);

// The pipeline's sink for `watch`: the state onto the display. Another sink (the
// telemetry sink, before this one) feeds the records into the state.
class WatchSink final : public RecordSink {
  public:
    WatchSink(SharedState& shared, Display& display) : shared_(shared), display_(display) {}
    void begin(const SessionInfo& /*session*/) override {}
    void record(const Record& record) override;
    void idle(Nanos now) override;
    void end(const Totals& totals, const std::vector<std::string>& remarks) override;

  private:
    SharedState& shared_;
    Display& display_;
    Nanos now_ = kNoTime;
};

}  // namespace rtuscope
