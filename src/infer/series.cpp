#include "infer/series.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdlib>

namespace rtuscope::infer {

WordSeries measure_word(const std::vector<Sample>& samples) {
    WordSeries s;
    s.samples = samples.size();
    if (samples.empty()) return s;
    s.min = s.max = samples.front().value;
    for (std::size_t i = 0; i < samples.size(); ++i) {
        const std::uint16_t v = samples[i].value;
        s.min = std::min(s.min, v);
        s.max = std::max(s.max, v);
        (v < 0x8000 ? s.below_sign : s.above_sign) = true;
        const auto as_signed = static_cast<std::int16_t>(v);
        if (as_signed % 10 != 0) s.multiples_of_10 = false;
        if (as_signed % 100 != 0) s.multiples_of_100 = false;
        if (!s.many_values()) {
            auto at = std::lower_bound(s.distinct.begin(), s.distinct.end(), v);
            if (at == s.distinct.end() || *at != v) s.distinct.insert(at, v);
        }
        if (i == 0) continue;
        const std::uint16_t prev = samples[i - 1].value;
        if (v == prev) continue;
        ++s.changes;
        if (v < prev) s.non_decreasing = false;
        s.max_step_unsigned =
            std::max(s.max_step_unsigned, static_cast<std::uint32_t>(std::abs(int{v} - int{prev})));
        s.max_step_signed = std::max(
            s.max_step_signed,
            static_cast<std::uint32_t>(std::abs(int{static_cast<std::int16_t>(v)} -
                                                int{static_cast<std::int16_t>(prev)})));
        const auto flipped = static_cast<std::uint16_t>(v ^ prev);
        if (std::popcount(flipped) != 1) s.single_bit_changes = false;
        s.toggled_bits = static_cast<std::uint16_t>(s.toggled_bits | flipped);
    }
    return s;
}

std::optional<PairSeries> read_together(const std::vector<Sample>& first,
                                        const std::vector<Sample>& second) {
    if (first.empty() || first.size() != second.size()) return std::nullopt;
    PairSeries pair;
    pair.first.reserve(first.size());
    pair.second.reserve(first.size());
    for (std::size_t i = 0; i < first.size(); ++i) {
        if (first[i].answer != second[i].answer) return std::nullopt;
        pair.first.push_back(first[i].value);
        pair.second.push_back(second[i].value);
    }
    return pair;
}

namespace {

struct Words {
    const std::vector<std::uint16_t>& high;
    const std::vector<std::uint16_t>& low;
};

Words words(const PairSeries& pair, HighWord high) {
    return high == HighWord::first ? Words{pair.first, pair.second}
                                   : Words{pair.second, pair.first};
}

}  // namespace

std::vector<std::uint32_t> join_words(const PairSeries& pair, HighWord high) {
    const Words w = words(pair, high);
    std::vector<std::uint32_t> values(w.high.size());
    for (std::size_t i = 0; i < values.size(); ++i) {
        values[i] = (std::uint32_t{w.high[i]} << 16) | w.low[i];
    }
    return values;
}

CarryCount count_carries(const PairSeries& pair, HighWord high) {
    const Words w = words(pair, high);
    CarryCount count;
    for (std::size_t i = 1; i < w.high.size(); ++i) {
        const auto high_step = static_cast<std::uint16_t>(w.high[i] - w.high[i - 1]);
        if (high_step == 0) continue;
        const bool low_wrapped_up = w.low[i - 1] >= 0xC000 && w.low[i] < 0x4000;
        const bool low_wrapped_down = w.low[i - 1] < 0x4000 && w.low[i] >= 0xC000;
        if ((high_step == 1 && low_wrapped_up) || (high_step == 0xFFFF && low_wrapped_down)) {
            ++count.carries;
        } else {
            ++count.unexplained_high_steps;
        }
    }
    return count;
}

FloatReading read_floats(const PairSeries& pair, HighWord high) {
    const Words w = words(pair, high);
    const std::vector<std::uint32_t> bits = join_words(pair, high);
    FloatReading r;
    if (bits.empty()) return r;
    r.all_sane = true;
    std::size_t smooth = 0;
    double prev = 0;
    for (std::size_t i = 0; i < bits.size(); ++i) {
        const auto x = static_cast<double>(std::bit_cast<float>(bits[i]));
        const double magnitude = std::fabs(x);
        if (!std::isfinite(x) || (x != 0 && (magnitude < 1e-6 || magnitude > 1e9))) {
            r.all_sane = false;
            return r;
        }
        if (i == 0) {
            r.min = r.max = x;
        } else {
            r.min = std::min(r.min, x);
            r.max = std::max(r.max, x);
            const double larger = std::max(std::fabs(prev), magnitude);
            if (larger == 0 || std::fabs(x - prev) <= 0.1 * larger) ++smooth;
            if (w.low[i] != w.low[i - 1]) ++r.low_word_changes;
            if (w.high[i] != w.high[i - 1]) ++r.high_word_changes;
        }
        prev = x;
    }
    r.varies = r.min != r.max;
    r.smooth_fraction =
        bits.size() < 2 ? 1.0 : static_cast<double>(smooth) / static_cast<double>(bits.size() - 1);
    return r;
}

SignedSteps signed_steps32(const std::vector<std::uint32_t>& values) {
    SignedSteps s;
    for (std::size_t i = 0; i < values.size(); ++i) {
        (values[i] & 0x80000000U ? s.has_negative : s.has_positive) = true;
        if (i == 0) continue;
        const auto u_step = static_cast<std::uint64_t>(
            std::llabs(static_cast<long long>(values[i]) - static_cast<long long>(values[i - 1])));
        const auto s_step = static_cast<std::uint64_t>(
            std::llabs(static_cast<long long>(static_cast<std::int32_t>(values[i])) -
                       static_cast<long long>(static_cast<std::int32_t>(values[i - 1]))));
        s.max_step_unsigned = std::max(s.max_step_unsigned, u_step);
        s.max_step_signed = std::max(s.max_step_signed, s_step);
    }
    return s;
}

}  // namespace rtuscope::infer
