// SPDX-License-Identifier: MIT
// imucal/stream/ring.hpp: a ring of at most N values, oldest first, in fixed memory: the delay
// line of still blocks, the initial rest's quarters, the rests waiting to be taken. Never
// allocates, throws or blocks. Header-only.
#pragma once

#include <cstddef>

namespace imucal {

template <typename T, int N>
class Ring {
 public:
  static_assert(N >= 1, "a ring holds at least one value");
  static constexpr int kCapacity = N;

  void clear() { head_ = count_ = 0; }
  int size() const { return count_; }
  bool empty() const { return count_ == 0; }
  bool full() const { return count_ == N; }

  // The k-th oldest (0: the oldest), for 0 <= k < size().
  const T& at(int k) const { return items_[index(k)]; }
  T& at(int k) { return items_[index(k)]; }
  const T& oldest() const { return items_[index(0)]; }
  const T& newest() const { return items_[index(count_ - 1)]; }
  T& newest() { return items_[index(count_ - 1)]; }

  // Appends v; when full, the oldest goes first. True if one went.
  bool push(const T& v) {
    const bool overwrote = count_ == N;
    if (overwrote) pop();
    items_[index(count_)] = v;
    ++count_;
    return overwrote;
  }
  // Drops the oldest (size() > 0).
  void pop() {
    head_ = (head_ + 1) % N;
    --count_;
  }
  // Moves every value, oldest first, to f(value), leaving the ring empty.
  template <class F>
  void drain(const F& f) {
    while (count_ > 0) {
      f(items_[static_cast<std::size_t>(head_)]);
      pop();
    }
  }

 private:
  std::size_t index(int k) const { return static_cast<std::size_t>((head_ + k) % N); }

  T items_[static_cast<std::size_t>(N)] = {};
  int head_ = 0, count_ = 0;
};

}  // namespace imucal
