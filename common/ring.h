#pragma once
/// @file
/// A fixed-capacity ring buffer: storage allocated once at construction,
/// oldest first. The one ring of rocklab (comparator alignment, monitor
/// series and events, the DAQ's pairing of block and table states).

#include <cstddef>
#include <vector>

namespace rocklab::common {

template <typename T>
class Ring {
 public:
  /// @param capacity items kept; >= 1.
  explicit Ring(std::size_t capacity) : items_(capacity) {}
  std::size_t size() const { return size_; }
  std::size_t capacity() const { return items_.size(); }
  bool empty() const { return size_ == 0; }
  bool full() const { return size_ == items_.size(); }
  /// i = 0 is the oldest; i < size().
  T& operator[](std::size_t i) { return items_[(head_ + i) % items_.size()]; }
  const T& operator[](std::size_t i) const { return items_[(head_ + i) % items_.size()]; }
  T& front() { return (*this)[0]; }
  const T& front() const { return (*this)[0]; }
  T& back() { return (*this)[size_ - 1]; }
  const T& back() const { return (*this)[size_ - 1]; }
  /// Appends; when full the oldest is overwritten and false is returned.
  bool push_back(const T& v) {
    const bool had_room = !full();
    if (!had_room) pop_front();
    items_[(head_ + size_) % items_.size()] = v;
    ++size_;
    return had_room;
  }
  /// Precondition: !empty().
  void pop_front() {
    head_ = (head_ + 1) % items_.size();
    --size_;
  }
  void clear() { head_ = size_ = 0; }

 private:
  std::vector<T> items_;
  std::size_t head_{};
  std::size_t size_{};
};

}  // namespace rocklab::common
