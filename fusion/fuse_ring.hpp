#pragma once
// A ring of values in order, for ips-fuse's history and its snapshots: push at the back, pop at
// the front, truncate, insert in the middle (a late message), indexed access. Unlike std::deque
// of these large values (one heap node per element), it allocates only when it grows: a message
// fused costs no allocation once the ring holds max_delay_s of them. Popped and truncated slots
// keep their old values until overwritten.
#include <cstddef>
#include <utility>
#include <vector>

namespace ips::fusion {

template <class T>
class Ring {
 public:
  size_t size() const { return n_; }
  bool empty() const { return n_ == 0; }
  T& operator[](size_t i) { return buf_[(head_ + i) & mask_]; }
  const T& operator[](size_t i) const { return buf_[(head_ + i) & mask_]; }
  T& front() { return (*this)[0]; }
  const T& front() const { return (*this)[0]; }
  T& back() { return (*this)[n_ - 1]; }
  const T& back() const { return (*this)[n_ - 1]; }

  void push_back(const T& v) {
    if (n_ == buf_.size()) {
      T copy = v;  // v may be one of ours
      push_back(std::move(copy));
      return;
    }
    buf_[(head_ + n_) & mask_] = v;
    ++n_;
  }
  void push_back(T&& v) {
    if (n_ == buf_.size()) grow();
    buf_[(head_ + n_) & mask_] = std::move(v);
    ++n_;
  }
  void pop_front() {
    head_ = (head_ + 1) & mask_;
    --n_;
  }
  void clear() {
    head_ = 0;
    n_ = 0;
  }
  // Keeps the first k (k <= size()).
  void truncate(size_t k) { n_ = k; }
  // Before index i (i <= size()): the later ones move one place back.
  void insert(size_t i, T v) {
    push_back(std::move(v));
    for (size_t j = n_ - 1; j > i; --j) std::swap((*this)[j], (*this)[j - 1]);
  }
  // The first index whose key(element) is greater than `v` (the values ordered by key), as
  // std::upper_bound finds it.
  template <class V, class Key>
  size_t upper_bound(const V& v, Key&& key) const {
    size_t lo = 0, len = n_;
    while (len > 0) {
      const size_t half = len / 2;
      if (v < key((*this)[lo + half])) {
        len = half;
      } else {
        lo += half + 1;
        len -= half + 1;
      }
    }
    return lo;
  }

 private:
  void grow() {
    std::vector<T> bigger(buf_.empty() ? 16 : 2 * buf_.size());
    for (size_t i = 0; i < n_; ++i) bigger[i] = std::move((*this)[i]);
    buf_ = std::move(bigger);
    mask_ = buf_.size() - 1;
    head_ = 0;
  }

  std::vector<T> buf_;  // a power of two in size
  size_t mask_ = 0;
  size_t head_ = 0;
  size_t n_ = 0;
};

}  // namespace ips::fusion
