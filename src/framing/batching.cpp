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
// A FIFO's trigger level is at least this (a 16550's are 1, 4, 8 and 14 bytes).
constexpr std::size_t kFewestFifoBytes = 4;

// Milliseconds as an adapter's settings give them: whole above 2 ms (a chunk after a
// latency timer's run comes a little later than the timer, when the next byte ends).
std::string ms_text(Nanos t) {
    const double ms = static_cast<double>(t) / 1e6;
    return ms >= 2.0 ? fmt::format("{:.0f}", ms) : fmt::format("{:.2g}", ms);
}

// The size that most chunks counted have (of sizes tied, the smallest).
using SizeCounts = std::map<std::size_t, std::size_t>;
SizeCounts::const_iterator commonest(const SizeCounts& counts) {
    return std::ranges::max_element(
        counts, [](const auto& a, const auto& b) { return a.second < b.second; });
}

// How far apart a sender's characters are: the line's character time, or more where it
// pauses between them (at most a quarter character here). Learned from the chunks whose
// bytes may have come back to back, the commonest size of them: the median of their
// intervals, per byte.
Nanos sender_pace(const std::vector<BatchingLearner::Sample>& samples, Nanos ct) {
    const auto may_be_back_to_back = [&](const BatchingLearner::Sample& s) {
        const Nanos line_pace = s.bytes_at(ct);
        return s.bytes >= kFewestFifoBytes && s.interval + ct / 2 >= line_pace &&
               s.interval <= line_pace + line_pace / 4 + ct / 2;
    };
    SizeCounts sizes;
    for (const auto& s : samples) {
        if (may_be_back_to_back(s)) ++sizes[s.bytes];
    }
    if (sizes.empty()) return ct;
    const std::size_t size = commonest(sizes)->first;
    std::vector<Nanos> paces;
    for (const auto& s : samples) {
        if (s.bytes == size && may_be_back_to_back(s)) {
            paces.push_back(s.interval / static_cast<Nanos>(s.bytes));
        }
    }
    const auto middle = paces.begin() + static_cast<std::ptrdiff_t>(paces.size() / 2);
    std::nth_element(paces.begin(), middle, paces.end());
    return std::max(ct, *middle);
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
    const bool sampled = has_time(last_time_) && chunk.time > last_time_ &&
                         chunk.time - last_time_ <= kLongestInterval;
    if (sampled) {
        samples_.push_back({chunk.time - last_time_, chunk.bytes.size(), last_sampled_});
    }
    last_sampled_ = sampled;
    last_time_ = chunk.time;
}

Batching BatchingLearner::verdict() const {
    Batching batching;
    if (chunks_ < kFewestChunks || samples_.size() < kFewestChunks) return batching;
    const Nanos ct = char_time_;
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
        return s.bytes < largest && s.bytes_at(ct) + ct <= s.interval;
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
    // its period falls between characters); and mostly followed by the rest of their
    // frame, handed over after the FIFO's receive timeout (whole frames a chunk each, at
    // a steady poll, are not). Back to back at the sender's pace: some senders pause
    // between characters (the flow meter in captures/realdata, a bit each time).
    const Nanos pace = sender_pace(samples_, ct);
    const auto came_back_to_back = [&](const Sample& s) {
        return s.bytes >= kFewestFifoBytes && std::abs(s.interval - s.bytes_at(pace)) <= ct / 2;
    };
    SizeCounts full;
    std::size_t back_to_back = 0;
    for (const Sample& s : samples_) {
        if (came_back_to_back(s)) {
            ++full[s.bytes];
            ++back_to_back;
        }
    }
    const auto trigger = commonest(full);
    if (trigger == full.end() || trigger->second < kFewestChunks ||
        trigger->second * 100 < samples_.size() * 5 || trigger->second * 10 < back_to_back * 9) {
        return batching;
    }
    std::size_t continued = 0;
    for (std::size_t i = 0; i + 1 < samples_.size(); ++i) {
        const Sample& s = samples_[i];
        const Sample& next = samples_[i + 1];
        if (s.bytes == trigger->first && came_back_to_back(s) && next.follows_previous &&
            next.interval <= next.bytes_at(pace) + kFifoTimeoutChars * ct + ct) {
            ++continued;
        }
    }
    if (continued * 2 < trigger->second) return batching;
    batching.kind = Batching::Kind::fifo;
    batching.fifo_trigger = trigger->first;
    // A chunk's bytes are placed back to back at the line's pace before its time: a
    // slower sender's first byte began earlier, so a silence measured before a full
    // chunk may be that much longer too.
    batching.hold = kFifoTimeoutChars * ct + ct / 2 +
                    static_cast<Nanos>(trigger->first) * (pace - ct);
    return batching;
}

}  // namespace rtuscope
