#include "util/time.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cstring>
#include <ctime>

namespace rtuscope {

Nanos clock_ns(clockid_t clock) {
    timespec ts{};
    clock_gettime(clock, &ts);
    return static_cast<Nanos>(ts.tv_sec) * kNanosPerSecond + ts.tv_nsec;
}

std::int64_t days_from_civil(std::int64_t year, unsigned month, unsigned day) {
    year -= month <= 2 ? 1 : 0;
    const std::int64_t era = (year >= 0 ? year : year - 399) / 400;
    const auto yoe = static_cast<unsigned>(year - era * 400);
    const unsigned doy = (153 * (month > 2 ? month - 3 : month + 9) + 2) / 5 + day - 1;
    const unsigned doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    return era * 146097 + static_cast<std::int64_t>(doe) - 719468;
}

CivilDate civil_from_days(std::int64_t days) {
    days += 719468;
    const std::int64_t era = (days >= 0 ? days : days - 146096) / 146097;
    const auto doe = static_cast<unsigned>(days - era * 146097);
    const unsigned yoe = (doe - doe / 1460 + doe / 36524 - doe / 146096) / 365;
    const unsigned doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    const unsigned mp = (5 * doy + 2) / 153;
    const unsigned day = doy - (153 * mp + 2) / 5 + 1;
    const unsigned month = mp < 10 ? mp + 3 : mp - 9;
    const std::int64_t year = static_cast<std::int64_t>(yoe) + era * 400 + (month <= 2 ? 1 : 0);
    return {year, month, day};
}

LocalTime local_time(std::int64_t unix_seconds) {
    LocalTime out;
    const auto t = static_cast<std::time_t>(unix_seconds);
    std::tm tm{};
    if (localtime_r(&t, &tm) == nullptr) {
        // Beyond what the C library converts: shown as UTC rather than not at all.
        out.date = civil_from_days(floor_div(unix_seconds, 86'400));
        out.second_of_day = floor_mod(unix_seconds, 86'400);
        return out;
    }
    out.date = {std::int64_t{tm.tm_year} + 1900, static_cast<unsigned>(tm.tm_mon + 1),
                static_cast<unsigned>(tm.tm_mday)};
    out.second_of_day = (std::int64_t{tm.tm_hour} * 60 + tm.tm_min) * 60 + tm.tm_sec;
    out.utc_offset = tm.tm_gmtoff;
    if (tm.tm_zone != nullptr) {
        const std::size_t n = std::min(std::strlen(tm.tm_zone), out.zone.size() - 1);
        std::memcpy(out.zone.data(), tm.tm_zone, n);
    }
    return out;
}

std::optional<std::int64_t> unix_from_local(CivilDate date, std::int64_t second_of_day) {
    std::tm tm{};
    tm.tm_year = static_cast<int>(date.year - 1900);
    tm.tm_mon = static_cast<int>(date.month) - 1;
    tm.tm_mday = static_cast<int>(date.day);
    tm.tm_hour = static_cast<int>(second_of_day / 3600);
    tm.tm_min = static_cast<int>(second_of_day / 60 % 60);
    tm.tm_sec = static_cast<int>(second_of_day % 60);
    tm.tm_isdst = -1;  // the zone's rules say whether summer time applies
    const std::time_t t = std::mktime(&tm);
    // -1 is also 1969-12-31 23:59:59 UTC, which no capture of a Modbus bus holds.
    if (t == static_cast<std::time_t>(-1)) return std::nullopt;
    return static_cast<std::int64_t>(t);
}

std::string utc_text(Nanos time) {
    const std::int64_t seconds = floor_div(time, kNanosPerSecond);
    const std::int64_t day = floor_div(seconds, 86'400);
    const std::int64_t second_of_day = seconds - day * 86'400;
    const CivilDate date = civil_from_days(day);
    return fmt::format("{:04}-{:02}-{:02}T{:02}:{:02}:{:02}Z", date.year, date.month, date.day,
                       second_of_day / 3600, second_of_day / 60 % 60, second_of_day % 60);
}

}  // namespace rtuscope
