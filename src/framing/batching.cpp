#include "framing/batching.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cstdlib>
#include <map>

namespace rtuscope {
namespace {

// A 16550-style UART hands over what its FIFO holds once the line has been quiet for 4
// characters (its receive timeout), so those bytes are stamped up to that much late.
constexpr Nanos kFifoTimeoutChars = 4;
// Chunks farther apart than this are idle time, not batching.
constexpr Nanos kLongestInterval = kNanosPerSecond;
// Fewer chunks say nothing about how the input batches.
constexpr std::size_t kFewestChunks = 16;

// Milliseconds as an adapter's settings give them: whole above 2 ms (a chunk after a
// latency timer's run comes a little later than the timer, when the next byte ends).
std::string ms_text(Nanos t) {
    const double ms = static_cast<double>(t) / 1e6;
    return ms >= 2.0 ? fmt::format("{:.0f}", ms) : fmt::format("{:.2g}", ms);
}

}  // namespace

std::string Batching::text() const {
    switch (kind) {
        case Kind::unknown:
        case Kind::per_byte:
            return {};
        case Kind::timer:
            return fmt::format("chunks every {} ms: silences under {} ms cannot be seen",
                               ms_text(period), ms_text(hold));
        case Kind::fifo:
            return fmt::format(
                "chunks of {} bytes, the rest after a pause (a UART FIFO): silences under {} ms "
                "cannot be seen",
                fifo_trigger, ms_text(hold));
    }
    return {};
}

void BatchingLearner::chunk(const Chunk& chunk) {
    // Times out of range stop the pipeline; they must not overflow an interval first.
    if (settled() || chunk.bytes.empty() || !has_time(chunk.time) ||
        std::abs(chunk.time) > kMaxTime) {
        return;
    }
    ++chunks_;
    if (chunk.bytes.size() == 1) ++single_bytes_;
    if (has_time(last_time_) && chunk.time > last_time_ &&
        chunk.time - last_time_ <= kLongestInterval) {
        samples_.push_back({chunk.time - last_time_, chunk.bytes.size()});
    }
    last_time_ = chunk.time;
}

Batching BatchingLearner::verdict() const {
    Batching batching;
    if (chunks_ < kFewestChunks || samples_.size() < kFewestChunks) return batching;
    const Nanos ct = char_time_;
    const auto bytes_time = [&](const Sample& s) { return static_cast<Nanos>(s.bytes) * ct; };
    if (single_bytes_ * 5 >= chunks_ * 4) {
        batching.kind = Batching::Kind::per_byte;
        return batching;
    }

    // A latency timer: no chunk held by it comes sooner than its period after the one
    // before, and many come just then, whatever their size: held until the timer ran out.
    // (A chunk handed over full, at the largest size, comes sooner. Chunks a frame each,
    // polled at a steady rhythm, also pile up at one interval, but one that grows with
    // their sizes.)
    std::size_t largest = 0;
    for (const Sample& s : samples_) largest = std::max(largest, s.bytes);
    const auto held = [&](const Sample& s) {
        return s.bytes < largest && bytes_time(s) + ct <= s.interval;
    };
    std::vector<Nanos> intervals;
    for (const Sample& s : samples_) {
        if (held(s)) intervals.push_back(s.interval);
    }
    if (intervals.size() >= kFewestChunks) {
        const auto tenth = intervals.begin() + static_cast<std::ptrdiff_t>(intervals.size() / 10);
        std::nth_element(intervals.begin(), tenth, intervals.end());
        const Nanos typical = *tenth;
        const Nanos below = typical / 50 + 50'000;
        const Nanos above = std::max(2 * ct, typical / 4);
        std::size_t piled = 0;
        std::size_t fewest = ~std::size_t{0};
        std::size_t most = 0;
        Nanos period = typical;
        for (const Sample& s : samples_) {
            if (!held(s) || s.interval + below < typical || s.interval > typical + above) continue;
            ++piled;
            fewest = std::min(fewest, s.bytes);
            most = std::max(most, s.bytes);
            period = std::min(period, s.interval);
        }
        const bool sizes_vary =
            piled != 0 && static_cast<Nanos>(most - fewest) * ct > below + above + ct;
        if (typical >= 2 * ct && piled * 5 >= intervals.size() && sizes_vary) {
            batching.kind = Batching::Kind::timer;
            batching.period = period;
            batching.hold = period;
            return batching;
        }
    }

    // A UART FIFO: chunks of its trigger level whose bytes came back to back, handed over
    // as the last one came; all of one size (a timer's full chunks differ by a byte as
    // its period falls between characters).
    std::map<std::size_t, std::size_t> full;
    std::size_t back_to_back = 0;
    for (const Sample& s : samples_) {
        if (s.bytes >= 4 && std::abs(s.interval - bytes_time(s)) <= ct / 2) {
            ++full[s.bytes];
            ++back_to_back;
        }
    }
    const auto trigger = std::ranges::max_element(
        full, [](const auto& a, const auto& b) { return a.second < b.second; });
    if (trigger != full.end() && trigger->second >= kFewestChunks &&
        trigger->second * 100 >= samples_.size() * 5 && trigger->second * 10 >= back_to_back * 9) {
        batching.kind = Batching::Kind::fifo;
        batching.fifo_trigger = trigger->first;
        batching.hold = kFifoTimeoutChars * ct + ct / 2;
    }
    return batching;
}

}  // namespace rtuscope
