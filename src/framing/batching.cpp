#include "framing/batching.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cstdlib>
#include <functional>
#include <map>
#include <set>

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
// A timer's chunks are cut wherever its period falls: at least this many sizes among them.
constexpr std::size_t kFewestTimerSizes = 3;

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
// pauses between them (up to t1.5, as the spec allows within a frame). Learned from the
// chunks whose bytes may have come back to back at some such pace: a FIFO's full chunks,
// each the same bytes at the same pace, agree within a character. Of the sizes with that
// many agreeing (the rest of a frame, handed over after the receive timeout, may agree as
// well, but is smaller), the largest; the median of its agreeing intervals, per byte.
Nanos sender_pace(const std::vector<BatchingLearner::Sample>& samples, Nanos ct, Nanos slowest) {
    std::map<std::size_t, std::vector<Nanos>, std::greater<>> intervals_by_size;  // largest first
    for (const auto& s : samples) {
        if (s.bytes >= kFewestFifoBytes && s.interval + ct / 2 >= s.bytes_at(ct) &&
            s.interval <= s.bytes_at(slowest) + ct / 2) {
            intervals_by_size[s.bytes].push_back(s.interval);
        }
    }
    for (auto& [size, intervals] : intervals_by_size) {
        std::ranges::sort(intervals);
        std::size_t most_agreeing = 0;
        Nanos pace = ct;
        for (std::size_t first = 0, last = 0; first < intervals.size(); ++first) {
            while (last < intervals.size() && intervals[last] - intervals[first] <= ct) ++last;
            if (last - first > most_agreeing) {
                most_agreeing = last - first;
                pace = intervals[(first + last) / 2] / static_cast<Nanos>(size);
            }
        }
        if (most_agreeing >= kFewestChunks) return std::max(ct, pace);
    }
    return ct;
}

// How much longer the samples' intervals are for each byte more they hold: the slope of
// the least-squares line through them (of at least two sizes).
double growth_per_byte(const std::vector<const BatchingLearner::Sample*>& samples) {
    double mean_bytes = 0;
    double mean_interval = 0;
    for (const auto* s : samples) {
        mean_bytes += static_cast<double>(s->bytes);
        mean_interval += static_cast<double>(s->interval);
    }
    mean_bytes /= static_cast<double>(samples.size());
    mean_interval /= static_cast<double>(samples.size());
    double covariance = 0;
    double variance = 0;
    for (const auto* s : samples) {
        const double bytes = static_cast<double>(s->bytes) - mean_bytes;
        covariance += bytes * (static_cast<double>(s->interval) - mean_interval);
        variance += bytes * bytes;
    }
    return covariance / variance;
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
    // their sizes, by a character or more a byte. A timer's are of several sizes, however
    // slow the sender: the last of each frame's is of any size.)
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
        std::vector<const Sample*> piled;
        std::set<std::size_t> sizes;
        Nanos period = typical;
        for (const Sample& s : samples_) {
            if (!held(s) || s.interval + below < typical || s.interval > typical + above) continue;
            piled.push_back(&s);
            sizes.insert(s.bytes);
            period = std::min(period, s.interval);
        }
        if (typical >= 2 * ct && piled.size() * 5 >= intervals.size() &&
            sizes.size() >= kFewestTimerSizes &&
            growth_per_byte(piled) < static_cast<double>(ct) / 2) {
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
    const Nanos pace = sender_pace(samples_, ct, slowest_pace_);
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
    batching.hold =
        kFifoTimeoutChars * ct + ct / 2 + static_cast<Nanos>(trigger->first) * (pace - ct);
    return batching;
}

}  // namespace rtuscope
