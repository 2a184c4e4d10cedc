// Times are integer nanoseconds in the input's own timebase (absolute Unix time or
// relative, whatever the capture holds). kNoTime marks input that carries no timing.
#pragma once

#include <cstdint>
#include <limits>

namespace rtuscope {

using Nanos = std::int64_t;
inline constexpr Nanos kNoTime = std::numeric_limits<Nanos>::min();
inline constexpr Nanos kNanosPerSecond = 1'000'000'000;

inline constexpr bool has_time(Nanos t) {
    return t != kNoTime;
}

}  // namespace rtuscope
