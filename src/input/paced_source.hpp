// A capture replayed at its own pace (`watch FILE --speed N`): each chunk is delivered when
// its time, counted from the first chunk's and divided by the speed, has passed on the
// wall clock. While it waits, the source says every `tick` that nothing came until the
// capture's present time (an empty chunk), so that a display stays alive.
#pragma once

#include <memory>

#include "input/chunk.hpp"

namespace rtuscope {

// `speed`: 1 for real time, 10 for ten times as fast; inputs without timing are passed
// on at once.
std::unique_ptr<ChunkSource> pace_source(std::unique_ptr<ChunkSource> source, double speed,
                                         Nanos tick = 100'000'000);

}  // namespace rtuscope
