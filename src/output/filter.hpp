// Record filters (--slave, --function, --kind, --from, --to) and sink combinators: a
// filter in front of a sink, and a tee that feeds several sinks (text and --pcap, or the
// output and sniff's closing statistics).
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "pipeline.hpp"
#include "util/result.hpp"
#include "util/time.hpp"

namespace rtuscope {

// A --from/--to value as given. What it stands for on the input's time line depends on
// what the input's times are (SourceInfo::time_base) and on its first record: place().
struct TimeBound {
    enum class Kind : std::uint8_t {
        seconds,      // "1763798400.5": the seconds of the CSV time column
        after_first,  // "+2.5": seconds after the first record
        time_of_day,  // "08:00:01.5": on the first record's day, or the next day if that
                      // is before the first record's time of day
        date_time,    // "2026-11-21 08:00:01.5" (or with a T)
    };
    Kind kind = Kind::seconds;
    Nanos nanos = 0;  // the seconds; for time_of_day and date_time, since midnight
    CivilDate date;   // date_time

    // The time on the input's time line, or nullopt where it has none (no such time: a
    // time of day with relative times, a date with times of day only). A time of day or a
    // date is local time for absolute times (TZ applies, as the text shows them), as read
    // for times read without a zone. `first`: the first timed record's start.
    [[nodiscard]] std::optional<Nanos> place(TimeBase base, Nanos first) const;
};

struct RecordFilter {
    using Ranges = std::vector<std::pair<unsigned, unsigned>>;
    Ranges slaves;                   // empty: any
    Ranges functions;                // function & 0x7F, so exceptions match their function
    std::vector<std::string> kinds;  // request, response, ... noise, or "flagged"
    std::optional<TimeBound> from;   // frame start
    std::optional<TimeBound> to;

    [[nodiscard]] bool empty() const;
    // `from_at` and `to_at`: from and to placed on the input's times (TimeBound::place);
    // a record is in the range only when both bounds given are placed.
    [[nodiscard]] bool matches(const Record& record, std::optional<Nanos> from_at,
                               std::optional<Nanos> to_at) const;
};

// "1,3,10-20,0x10" (decimal or 0x hex, inclusive ranges) up to `max`.
Result<RecordFilter::Ranges> parse_ranges(std::string_view text, unsigned max);
// "request,exception,flagged": the CSV kinds, and "flagged" for any record with a note.
Result<std::vector<std::string>> parse_kinds(std::string_view text);
// "1763798400.5" (the CSV time column's seconds), "+2.5" (after the first record),
// "08:00:01[.5]" (a time of day), "2026-11-21 08:00:01[.5]" (also with a T).
Result<TimeBound> parse_time_bound(std::string_view text);
// Whether `bound` can be placed on times of this base: an Error saying why not (a time of
// day for relative times, a date for times of day only). Untimed input is no error: no
// record is in any time range.
Status check_time_bound(const TimeBound& bound, TimeBase base);

std::unique_ptr<RecordSink> make_filter_sink(RecordFilter filter,
                                             std::unique_ptr<RecordSink> inner);
std::unique_ptr<RecordSink> make_tee_sink(std::vector<std::unique_ptr<RecordSink>> sinks);

}  // namespace rtuscope
