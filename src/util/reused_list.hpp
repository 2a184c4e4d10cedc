// A list whose items outlive clear(), for what a record carries in numbers that vary
// from record to record (a decoded frame's register values and their notes).
#pragma once

#include <cstddef>
#include <span>
#include <vector>

namespace rtuscope {

// Records are reused, and a std::vector's clear() destroys its items with their strings:
// a decode with a device profile then allocated about once per register value, for its
// name, its text and its notes. Here clear() only forgets how many items are in use, and
// add() hands back an old item emptied by its own clear(), which keeps its buffers. Once
// the list has held as many items as a record needs, filling it allocates nothing.
// T::clear() empties an item and keeps its buffers.
template <class T>
class ReusedList {
  public:
    // A new, empty item at the end.
    T& add() {
        if (size_ == items_.size()) {
            items_.emplace_back();
        } else {
            items_[size_].clear();
        }
        return items_[size_++];
    }
    void clear() { size_ = 0; }

    [[nodiscard]] std::size_t size() const { return size_; }
    [[nodiscard]] bool empty() const { return size_ == 0; }
    const T& operator[](std::size_t i) const { return items_[i]; }
    const T* begin() const { return items_.data(); }
    const T* end() const { return items_.data() + size_; }
    // The items in use, for code that takes any list of them.
    operator std::span<const T>() const { return {items_.data(), size_}; }

  private:
    std::vector<T> items_;  // items_[size_..] are kept for their buffers
    std::size_t size_ = 0;
};

}  // namespace rtuscope
