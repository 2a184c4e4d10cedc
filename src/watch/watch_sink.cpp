#include <fmt/format.h>

#include <limits>

#include "state/state_text.hpp"
#include "util/text.hpp"
#include "watch/watch.hpp"

namespace rtuscope {

void WatchSink::record(const Record& /*record*/) {
    const std::lock_guard lock(shared_.mutex);
    const BusState& state = shared_.state;
    if (has_time(state.last_time()) && (!has_time(now_) || state.last_time() > now_)) {
        now_ = state.last_time();
    }
    display_.show(shared_.state, now_);
}

void WatchSink::idle(Nanos now) {
    const std::lock_guard lock(shared_.mutex);
    if (has_time(now) && (!has_time(now_) || now > now_)) now_ = now;
    display_.show(shared_.state, now_);
}

void WatchSink::end(const Totals& /*totals*/, const std::vector<std::string>& /*remarks*/) {
    display_.finish(shared_, now_);
}

namespace {

class PlainDisplay final : public Display {
  public:
    PlainDisplay(std::FILE* out, Nanos interval) : out_(out), interval_(interval) {}

    void show(BusState& state, Nanos now) override {
        if (!has_time(now)) return;
        if (!has_time(next_)) {
            next_ = now + interval_;
            return;
        }
        if (now < next_) return;
        print(state, now);
        // After a long silence, the next table is an interval from now, not a burst.
        next_ = now - next_ >= interval_ ? now + interval_ : next_ + interval_;
    }

    void finish(SharedState& shared, Nanos now) override {
        const std::lock_guard lock(shared.mutex);
        print(shared.state, now);
    }

  private:
    void print(BusState& state, Nanos now) {
        state.refresh();
        StateView view;
        view.now = now;
        std::string text = "-- at ";
        if (!has_time(now)) {
            text += "the end (no timing)";
        } else if (time_base_of(now) == TimeBase::unix_time) {
            // The local time of day, with the date on the first table and whenever it
            // changes: a run left for weeks reads as a log does.
            const LocalTime local = local_time(floor_div(now, kNanosPerSecond));
            const std::int64_t day = days_from_civil(local.date.year, local.date.month, local.date.day);
            if (day != shown_day_) {
                shown_day_ = day;
                text += fmt::format("{:04}-{:02}-{:02} ", local.date.year, local.date.month,
                                    local.date.day);
            }
            text += fmt::format("{:02}:{:02}:{:02}", local.second_of_day / 3600,
                                local.second_of_day / 60 % 60, local.second_of_day % 60);
        } else {
            append_seconds(text, now);
        }
        text += '\n';
        if (const std::string status = recording(); !status.empty()) text += status + '\n';
        text += state_text(state, view);
        text += '\n';
        std::fputs(text.c_str(), out_);
        std::fflush(out_);
    }

    std::FILE* out_;
    Nanos interval_;
    Nanos next_ = kNoTime;
    std::int64_t shown_day_ = std::numeric_limits<std::int64_t>::min();
};

}  // namespace

std::unique_ptr<Display> make_plain_display(std::FILE* out, Nanos interval) {
    return std::make_unique<PlainDisplay>(out, interval);
}

}  // namespace rtuscope
