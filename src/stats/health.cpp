#include "stats/health.hpp"

#include <fmt/format.h>

#include "util/text.hpp"
#include "util/time.hpp"

namespace rtuscope {

std::string totals_text(const Totals& totals) {
    const auto n = [](std::uint64_t count, std::string_view one, std::string_view many) {
        return fmt::format("{} {}", count, plural(count, one, many));
    };
    return fmt::format("{} ({}, {}, {}), {} ({} bad CRC, {} invalid, {}), {} without answer",
                       n(totals.records - totals.noise_runs, "frame", "frames"),
                       n(totals.requests, "request", "requests"),
                       n(totals.responses, "answer", "answers"),
                       n(totals.exceptions, "exception", "exceptions"),
                       n(totals.crc_bad + totals.invalid + totals.noise_runs, "error", "errors"),
                       totals.crc_bad, totals.invalid,
                       n(totals.noise_bytes, "noise byte", "noise bytes"),
                       n(totals.unanswered, "request", "requests"));
}

namespace {

class HealthSink final : public RecordSink {
  public:
    HealthSink(HealthOptions options, std::unique_ptr<RecordSink> inner)
        : options_(std::move(options)), inner_(std::move(inner)) {}

    void begin(const SessionInfo& session) override {
        clock_ = has_clock(session.source.time_base) &&
                 session.source.time_base != TimeBase::time_of_day;
        inner_->begin(session);
    }
    void record(const Record& record) override {
        passed(record.frame.start);
        count_record(day_, record);
        inner_->record(record);
    }
    void idle(Nanos now) override {
        passed(now);
        inner_->idle(now);
    }
    void flush() override { inner_->flush(); }
    void end(const Totals& totals, const std::vector<std::string>& remarks) override {
        inner_->end(totals, remarks);
    }

  private:
    // A day that ended before `time` is told.
    void passed(Nanos time) {
        if (!clock_ || !has_time(time)) return;
        if (!has_time(day_end_)) {
            start_day(time);
            return;
        }
        if (time < day_end_) return;
        std::string line = fmt::format("health of {:04}-{:02}-{:02}: {}", date_.year, date_.month,
                                       date_.day, totals_text(day_));
        if (options_.extra) {
            const std::string extra = options_.extra();
            if (!extra.empty()) line += "; " + extra;
        }
        options_.emit(line);
        day_ = Totals{};
        start_day(time);
    }

    void start_day(Nanos time) {
        const std::int64_t seconds = floor_div(time, kNanosPerSecond);
        const LocalTime local = local_time(seconds);
        date_ = local.date;
        // The next local midnight (a summer-time change moves it by the hour that day).
        day_end_ = (seconds - local.second_of_day + 86'400) * kNanosPerSecond;
    }

    HealthOptions options_;
    std::unique_ptr<RecordSink> inner_;
    bool clock_ = false;
    Totals day_;
    CivilDate date_;
    Nanos day_end_ = kNoTime;
};

}  // namespace

std::unique_ptr<RecordSink> make_health_sink(HealthOptions options,
                                             std::unique_ptr<RecordSink> inner) {
    return std::make_unique<HealthSink>(std::move(options), std::move(inner));
}

}  // namespace rtuscope
