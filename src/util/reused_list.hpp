// A list whose items outlive clear(): the one way a record's lists (its notes, its data
// blocks, its register values) keep their items' buffers from record to record.
#pragma once

#include <cstddef>
#include <span>
#include <utility>
#include <vector>

namespace rtuscope {

// Records are reused, and a std::vector's clear() destroys its items with their strings
// and vectors, which the next record then allocates again. Here clear() only forgets how
// many items are in use, and add() hands back an old item emptied by its own clear(),
// which keeps its buffers: once the list has held as many items as a record needs,
// filling it allocates nothing. T::clear() empties an item and keeps its buffers.
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
    // Takes back the last item (its buffers stay for the next add()).
    void pop_back() { --size_; }
    void clear() { size_ = 0; }
    void swap(ReusedList& other) noexcept {
        items_.swap(other.items_);
        std::swap(size_, other.size_);
    }

    [[nodiscard]] std::size_t size() const { return size_; }
    [[nodiscard]] bool empty() const { return size_ == 0; }
    T& operator[](std::size_t i) { return items_[i]; }
    const T& operator[](std::size_t i) const { return items_[i]; }
    T& back() { return items_[size_ - 1]; }
    const T& back() const { return items_[size_ - 1]; }
    T* begin() { return items_.data(); }
    T* end() { return items_.data() + size_; }
    const T* begin() const { return items_.data(); }
    const T* end() const { return items_.data() + size_; }
    // The items in use, for code that takes any list of them.
    operator std::span<const T>() const { return {items_.data(), size_}; }

  private:
    std::vector<T> items_;  // items_[size_..] are kept for their buffers
    std::size_t size_ = 0;
};

}  // namespace rtuscope
