// A run left on the bus for weeks says how the line did each day: at local midnight, one
// line for the day that ended (stderr, or syslog with --syslog), the closing summary's
// counts for that day alone.
#pragma once

#include <functional>
#include <memory>
#include <string>

#include "pipeline.hpp"

namespace rtuscope {

// "49 frames (25 requests, 24 answers, 0 exceptions), 0 errors (0 bad CRC, 0 invalid,
// 0 noise bytes), 0 requests without answer": the closing summary's counts.
std::string totals_text(const Totals& totals);

struct HealthOptions {
    // Where each day's line goes.
    std::function<void(const std::string& line)> emit;
    // What else to say of the day's end (the recording's files and windows); may be empty.
    std::function<std::string()> extra;
};

// Passes every record on to `inner` and counts it for its local day; the first record or
// idle tick of a new day emits "health of 2026-11-28: COUNTS" for the day before. Times
// without a clock (a relative capture) have no days.
std::unique_ptr<RecordSink> make_health_sink(HealthOptions options, std::unique_ptr<RecordSink> inner);

}  // namespace rtuscope
