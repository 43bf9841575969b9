#include "core/seq_loss.hpp"

#include <array>

namespace ips {

namespace {
// Counters of the devices we know wrap at one of these: the CAN frame's byte (256), 16-bit
// counters, and 31-bit ones (int32_t seq kept non-negative).
constexpr std::array<int64_t, 3> kWraps = {int64_t{1} << 8, int64_t{1} << 16, int64_t{1} << 31};
}  // namespace

void SeqLossCounter::observe(const std::string& key, int64_t seq) {
  if (seq < 0) {
    ++counts_.unknown;
    return;
  }
  auto it = last_.find(key);
  if (it == last_.end()) {
    if (last_.size() >= kMaxKeys) {
      ++counts_.unknown;
      return;
    }
    last_.emplace(key, seq);
    ++counts_.received;
    return;
  }
  ++counts_.received;
  int64_t& last = it->second;
  const int64_t step = seq - last;
  if (step == 1) {
    last = seq;
  } else if (step > 1) {
    if (step - 1 <= kMaxGap) {
      counts_.lost += step - 1;
    } else {
      ++counts_.restarts;
    }
    last = seq;
  } else if (-step <= kLateWindow) {
    ++counts_.late;  // a repeat or a late one: keep the newest number
  } else {
    // Back by more than the window: a wrap when the last number sat just below a wrap point and
    // this one just above 0 (the numbers in between were lost), else a restart.
    for (int64_t m : kWraps) {
      if (last < m) {
        const int64_t forward = seq + m - last;
        if (seq < m && forward > 0 && forward - 1 <= kLateWindow) {
          counts_.lost += forward - 1;
          last = seq;
          return;
        }
        break;
      }
    }
    ++counts_.restarts;
    last = seq;
  }
}

}  // namespace ips
