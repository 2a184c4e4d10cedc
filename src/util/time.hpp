// Times are integer nanoseconds in the input's own timebase (absolute Unix time or
// relative, whatever the capture holds). kNoTime marks input that carries no timing.
#pragma once

#include <cstdint>
#include <limits>

namespace rtuscope {

using Nanos = std::int64_t;
inline constexpr Nanos kNoTime = std::numeric_limits<Nanos>::min();
inline constexpr Nanos kNanosPerSecond = 1'000'000'000;
// The latest time (and, negated, the earliest) the pipeline decodes: about 142 years
// either side of zero, i.e. up to the year 2112 in Unix time. Bounded so that the
// difference of any two times (gaps, turnarounds, timeouts) fits in 64 bits: with the
// full range, a capture going from a very negative to a very positive time would overflow
// the framer's subtraction. run_pipeline stops with an error there.
inline constexpr Nanos kMaxTime = 4'500'000'000 * kNanosPerSecond;

inline constexpr bool has_time(Nanos t) {
    return t != kNoTime;
}

}  // namespace rtuscope
