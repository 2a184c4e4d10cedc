// Times are integer nanoseconds in the input's own timebase (TimeBase: absolute Unix time,
// a date and time as a log printed it, a time of day, or relative seconds). kNoTime marks
// input that carries no timing.
#pragma once

#include <array>
#include <cstdint>
#include <ctime>
#include <limits>
#include <string>
#include <optional>

namespace rtuscope {

using Nanos = std::int64_t;
inline constexpr Nanos kNoTime = std::numeric_limits<Nanos>::min();
inline constexpr Nanos kNanosPerSecond = 1'000'000'000;
inline constexpr Nanos kNanosPerDay = 86'400 * kNanosPerSecond;
// The latest time (and, negated, the earliest) the pipeline decodes: about 142 years
// either side of zero, i.e. up to the year 2112 in Unix time. Bounded so that the
// difference of any two times (gaps, turnarounds, timeouts) fits in 64 bits: with the
// full range, a capture going from a very negative to a very positive time would overflow
// the framer's subtraction. run_pipeline stops with an error there.
inline constexpr Nanos kMaxTime = 4'500'000'000 * kNanosPerSecond;

inline constexpr bool has_time(Nanos t) {
    return t != kNoTime;
}

// What a source's times mean (SourceInfo::time_base), and so how they are shown. The
// numbers are the same in every case (the CSV and JSONL `time`); only the text column and
// the --from/--to forms that name a date or a time of day depend on it.
enum class TimeBase : std::uint8_t {
    none,         // no times at all
    relative,     // seconds from an arbitrary zero (a capture with small times)
    unix_time,    // absolute: seconds since 1970-01-01 00:00 UTC (a pcap, a tty, a capture)
    wall_clock,   // a date and time read without a zone (a log's `2024-05-01 10:21:33.120`):
                  // counted as if it were UTC, shown as read, never converted
    time_of_day,  // a time of day without date or zone (a log's `09:00:00.480`): seconds
                  // since the first day's midnight, counting on past midnight
};

// Captures and pcap files say nothing of their times but the numbers: from 2001 on they
// are Unix time, smaller ones relative seconds.
inline constexpr Nanos kAbsoluteFrom = 1'000'000'000 * kNanosPerSecond;
inline constexpr TimeBase time_base_of(Nanos first_time) {
    if (!has_time(first_time)) return TimeBase::relative;
    return first_time >= kAbsoluteFrom ? TimeBase::unix_time : TimeBase::relative;
}

// Whether the times have a date (or at least a day) and a time of day to show.
inline constexpr bool has_clock(TimeBase base) {
    return base == TimeBase::unix_time || base == TimeBase::wall_clock ||
           base == TimeBase::time_of_day;
}

// A proleptic Gregorian date (H. Hinnant, "chrono-compatible low-level date
// algorithms"); no time zone or locale involved.
struct CivilDate {
    std::int64_t year = 1970;
    unsigned month = 1;  // 1-12
    unsigned day = 1;    // 1-31
};
// Days since 1970-01-01 of a date, and back.
std::int64_t days_from_civil(std::int64_t year, unsigned month, unsigned day);
CivilDate civil_from_days(std::int64_t days);

// "2026-11-28T03:12:01Z": a unix time in UTC, to the second.
std::string utc_text(Nanos time);

// The clock's time now (CLOCK_MONOTONIC for intervals, CLOCK_REALTIME for stamps).
Nanos clock_ns(clockid_t clock);

// Floor division and its remainder, for times before 1970 (or a log's zero).
inline constexpr std::int64_t floor_div(std::int64_t a, std::int64_t b) {
    return a / b - ((a % b != 0) && ((a < 0) != (b < 0)) ? 1 : 0);
}
inline constexpr std::int64_t floor_mod(std::int64_t a, std::int64_t b) {
    return a - floor_div(a, b) * b;
}

// A second of Unix time in the local zone (the C library's, so TZ applies): its date,
// its second of the day, its offset east of UTC and the zone's abbreviation ("CET").
struct LocalTime {
    CivilDate date;
    std::int64_t second_of_day = 0;
    std::int64_t utc_offset = 0;  // seconds
    std::array<char, 16> zone{};  // NUL-terminated, empty if the C library gives none
};
LocalTime local_time(std::int64_t unix_seconds);
// The Unix time of a local date and second of the day (a day past the month's end or a
// second past the day's end carries over), the zone's rules deciding summer time; nullopt
// if the C library cannot tell.
std::optional<std::int64_t> unix_from_local(CivilDate date, std::int64_t second_of_day);

}  // namespace rtuscope
