#include "drivers/phone_imu/clock_offset.hpp"

#include <algorithm>
#include <cmath>

namespace ips::phone_imu {

namespace {
int64_t us(double s) { return static_cast<int64_t>(std::llround(s * 1e6)); }
int64_t floor_div(int64_t a, int64_t b) { return a / b - ((a % b != 0) && ((a < 0) != (b < 0))); }
}  // namespace

ClockOffset::ClockOffset(ClockOffsetConfig config)
    : jump_us_(us(config.jump_s)), confirm_us_(us(config.confirm_s)) {
  // At most kBuckets buckets over the window: 1 s each for windows up to 64 s.
  const double bucket_s = std::max(1.0, config.window_s / kBuckets);
  bucket_us_ = us(bucket_s);
  window_buckets_ = std::clamp<int64_t>(
      static_cast<int64_t>(std::ceil(config.window_s / bucket_s)), 1, kBuckets);
}

void ClockOffset::clear() {
  used_ = 0;
  head_ = 0;
  above_ = false;
}

void ClockOffset::insert(int64_t host_us, int64_t d) {
  const int64_t index = floor_div(host_us, bucket_us_);
  if (used_ > 0 && index <= ring_[static_cast<size_t>(head_)].index) {
    // Same bucket, or the host clock stepped back: the newest bucket takes it.
    Bucket& b = ring_[static_cast<size_t>(head_)];
    b.min_d = std::min(b.min_d, d);
  } else {
    head_ = (head_ + 1) % kBuckets;
    ring_[static_cast<size_t>(head_)] = {index, d};
    used_ = std::min(used_ + 1, kBuckets);
  }
  recompute();
}

void ClockOffset::recompute() {
  const int64_t newest = ring_[static_cast<size_t>(head_)].index;
  int64_t best = ring_[static_cast<size_t>(head_)].min_d;
  int kept = 1;
  for (int k = 1; k < used_; ++k) {
    const Bucket& b = ring_[static_cast<size_t>((head_ - k + kBuckets) % kBuckets)];
    if (newest - b.index >= window_buckets_) break;  // older than the window: forgotten
    best = std::min(best, b.min_d);
    ++kept;
  }
  used_ = kept;
  offset_us_ = best;
}

bool ClockOffset::add(int64_t host_us, int64_t device_us) {
  const int64_t d = host_us - device_us;
  if (used_ == 0) {
    insert(host_us, d);
    return false;
  }
  if (d < offset_us_ - jump_us_) {  // earlier than possible: the phone clock jumped forward
    clear();
    ++resets_;
    insert(host_us, d);
    return true;
  }
  if (d > offset_us_ + jump_us_) {
    if (!above_) {
      above_ = true;
      above_since_us_ = host_us;
      above_min_d_ = d;
    } else {
      above_min_d_ = std::min(above_min_d_, d);
    }
    if (host_us - above_since_us_ >= confirm_us_) {  // the phone clock jumped back
      const int64_t best = above_min_d_;
      clear();
      ++resets_;
      insert(host_us, best);
      return true;
    }
    return false;  // late, or a jump not yet confirmed: not used
  }
  above_ = false;
  insert(host_us, d);
  return false;
}

}  // namespace ips::phone_imu
