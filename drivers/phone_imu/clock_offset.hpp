#pragma once
// Phone clock -> host clock. Every reading arrives with the phone's timestamp t_dev and the host's
// reception time t_host; d = t_host - t_dev is the clock offset plus a delay that is never
// negative (network, Wi-Fi power save, the app's batching). The least d over a sliding window of
// host time is the estimate with the least delay in it (the minimum-delay filter of NTP-style
// one-way synchronisation): it ignores jitter, whatever its size, as long as some reading in the
// window came through quickly; utime = t_dev + offset is then never later than the reception.
//
// The window (default 10 s, kept as the minima of 1 s buckets: constant memory) tracks drift: a
// phone clock slower than the host's raises d, which the window follows with a lag of at most
// window x drift (0.5 ms at 50 ppm). A jump of the phone clock (an app or phone restart, a clock
// set) is a reset: d falling more than jump_s below the estimate resets at once (a delay cannot
// be negative); d staying more than jump_s above it for confirm_s of host time resets to the
// least d of that stretch (a single late burst does not). Pure.
#include <array>
#include <cstdint>

namespace ips::phone_imu {

struct ClockOffsetConfig {
  double window_s = 10.0;
  double jump_s = 2.0;
  double confirm_s = 2.0;
};

class ClockOffset {
 public:
  explicit ClockOffset(ClockOffsetConfig config = {});
  // One reading; returns true when it reset the estimate (a jump).
  bool add(int64_t host_us, int64_t device_us);
  bool valid() const { return used_ > 0; }
  int64_t offset_us() const { return offset_us_; }
  int64_t resets() const { return resets_; }

 private:
  static constexpr int kBuckets = 64;
  struct Bucket {
    int64_t index;
    int64_t min_d;
  };
  void clear();
  void insert(int64_t host_us, int64_t d);
  void recompute();

  int64_t bucket_us_, window_buckets_, jump_us_, confirm_us_;
  std::array<Bucket, kBuckets> ring_{};
  int head_ = 0;  // newest
  int used_ = 0;
  int64_t offset_us_ = 0;
  int64_t resets_ = 0;
  bool above_ = false;  // readings above offset + jump since above_since_
  int64_t above_since_us_ = 0, above_min_d_ = 0;
};

}  // namespace ips::phone_imu
