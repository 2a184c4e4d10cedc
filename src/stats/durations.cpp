// DurationCounts: exact counts per distinct value, then bins as wide as the bound needs.
#include "stats/durations.hpp"

#include <algorithm>
#include <bit>
#include <cassert>
#include <limits>

namespace rtuscope {

void DurationCounts::add(Nanos value) {
    max_ = size_ == 0 ? value : std::max(max_, value);
    ++size_;
    added_.push_back(value);
    // Counted in batches (sort, then join), so that an add costs a few comparisons.
    if (added_.size() * 4 >= max_distinct_) finish();
}

void DurationCounts::limit(std::size_t max_distinct) {
    max_distinct_ = max_distinct;
    if (added_.size() * 4 >= max_distinct_) finish();
    fit();
    if (counts_.capacity() > max_distinct_ + max_distinct_ / 4) counts_.shrink_to_fit();
    if (added_.capacity() > max_distinct_ / 4) added_.shrink_to_fit();
}

void DurationCounts::finish() {
    if (added_.empty()) return;
    // One bin per value, sorted; absorb() joins the equal ones with those of a bin.
    std::sort(added_.begin(), added_.end());
    std::vector<Bin> bins;
    bins.reserve(added_.size());
    for (Nanos v : added_) bins.push_back({v, 1});
    added_.clear();
    absorb(bins);
}

void DurationCounts::merge(const DurationCounts& other) {
    assert(other.added_.empty() && "DurationCounts::finish() the other first");
    finish();
    if (other.empty()) return;
    max_ = empty() ? other.max_ : std::max(max_, other.max_);
    size_ += other.size_;
    widen_to(other.width_);
    absorb(other.counts_);
}

std::optional<Nanos> DurationCounts::percentile(unsigned percent) const {
    assert(added_.empty() && "DurationCounts::finish() first");
    if (empty()) return std::nullopt;
    if (percent >= 100) return max_;
    // Integer ceil(percent * n / 100): no floating-point rounding at exact ranks.
    const std::uint64_t rank = std::max<std::uint64_t>((percent * size_ + 99) / 100, 1);
    std::uint64_t reached = 0;
    for (const Bin& bin : counts_) {
        reached += bin.count;
        if (reached >= rank) return bin.smallest;
    }
    return max_;
}

Nanos DurationCounts::bin_of(Nanos value) const {
    // Rounded down, not towards zero: a bin of negative durations (times that step back
    // in a capture) is as wide as any other.
    const Nanos quotient = value / width_;
    return value % width_ < 0 ? quotient - 1 : quotient;
}

void DurationCounts::absorb(const std::vector<Bin>& sorted_bins) {
    std::vector<Bin> merged;
    merged.reserve(counts_.size() + sorted_bins.size());
    std::merge(counts_.begin(), counts_.end(), sorted_bins.begin(), sorted_bins.end(),
               std::back_inserter(merged),
               [](const Bin& a, const Bin& b) { return a.smallest < b.smallest; });
    counts_ = std::move(merged);
    join_bins();
    fit();
}

void DurationCounts::fit() {
    // The widths are 1 ns, then 1 µs doubled as often as it takes: each bin lies within
    // one of every wider width, so values counted at different widths still join exactly.
    constexpr Nanos kFirstWidth = 1000;
    while (counts_.size() > max_distinct_ && width_ <= std::numeric_limits<Nanos>::max() / 2) {
        widen_to(width_ == 1 ? kFirstWidth : width_ * 2);
    }
}

void DurationCounts::widen_to(Nanos width) {
    if (width <= width_) return;
    width_ = width;
    join_bins();
}

void DurationCounts::join_bins() {
    std::size_t kept = 0;
    for (const Bin& bin : counts_) {
        if (kept > 0 && bin_of(counts_[kept - 1].smallest) == bin_of(bin.smallest)) {
            counts_[kept - 1].count += bin.count;
        } else {
            counts_[kept++] = bin;
        }
    }
    counts_.resize(kept);
}

}  // namespace rtuscope
