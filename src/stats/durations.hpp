// Durations (turnarounds, poll cycles) counted for percentiles in bounded memory: the
// histograms behind `rtuscope stats`.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include "util/time.hpp"

namespace rtuscope {

// Durations (turnarounds, poll cycles) for nearest-rank percentiles, in bounded memory.
// Every distinct value is counted exactly while there are at most `max_distinct` of
// them; beyond that, values are counted in bins of 1 µs, then 2, 4, 8 µs ... (as wide as
// it takes to stay within the bound), each bin standing for the smallest value it holds.
// A percentile is the smallest value that at least `percent` per cent of the values are
// less than or equal to (sorted[ceil(percent/100 * n) - 1]): always a measured value,
// never an interpolation; once binned, at most one bin width below the exact one. The
// maximum is always exact. At most ~22 KiB however many values come (room for 1,280
// bins while counting, and 256 values waiting to be counted), ~22 bytes a bin allowed.
class DurationCounts {
  public:
    static constexpr std::size_t kMaxDistinct = 1024;
    DurationCounts() = default;
    explicit DurationCounts(std::size_t max_distinct) : max_distinct_(max_distinct) {}

    void add(Nanos value);
    // From now on holds at most `max_distinct` bins: widens them as far as that takes, and
    // gives back the room a larger bound had taken.
    void limit(std::size_t max_distinct);
    // Pools `other`'s values into these, at the wider of the two resolutions; `other`
    // must be finished.
    void merge(const DurationCounts& other);
    // Counts what add() gathered; percentile() needs it done first.
    void finish();

    [[nodiscard]] std::uint64_t size() const { return size_; }
    [[nodiscard]] bool empty() const { return size_ == 0; }
    [[nodiscard]] std::optional<Nanos> percentile(unsigned percent) const;
    // 0 while every value is counted exactly, else the width of a bin.
    [[nodiscard]] Nanos bin_width() const { return width_ == 1 ? 0 : width_; }
    // Distinct values or bins held: at most max_distinct after finish().
    [[nodiscard]] std::size_t held() const { return counts_.size(); }

  private:
    struct Bin {
        Nanos smallest;
        std::uint64_t count;
    };
    [[nodiscard]] Nanos bin_of(Nanos value) const;
    void absorb(const std::vector<Bin>& sorted_bins);
    void fit();  // widens the bins until there are at most max_distinct_
    void widen_to(Nanos width);
    void join_bins();  // of one bin at width_ into one, the smallest value kept

    std::size_t max_distinct_ = kMaxDistinct;
    Nanos width_ = 1;
    std::uint64_t size_ = 0;
    Nanos max_ = 0;
    std::vector<Bin> counts_;   // sorted; one per bin of width_
    std::vector<Nanos> added_;  // since the last count: at most a quarter of max_distinct
};

}  // namespace rtuscope
