// Phone clock -> host clock (drivers/phone_imu/clock_offset.hpp) on synthetic streams: a phone
// clock 1000 s behind the host, 100 Hz, delays of 3 ms plus seeded jitter up to 400 ms.
#include "drivers/phone_imu/clock_offset.hpp"

#include <gtest/gtest.h>

#include <random>

namespace ips::phone_imu {
namespace {

constexpr int64_t kHost0 = 1'700'000'000'000'000;
constexpr int64_t kTrueOffset = 1'000'000'000;  // host - phone

TEST(ClockOffset, MinimumDelayIgnoresJitter) {
  ClockOffset c;
  std::mt19937 rng(7);
  std::exponential_distribution<double> jitter(1.0 / 40'000);  // mean 40 ms, long tail
  for (int k = 0; k < 3000; ++k) {
    const int64_t phone = kHost0 - kTrueOffset + k * 10'000;
    const int64_t delay = 3'000 + std::min<int64_t>(static_cast<int64_t>(jitter(rng)), 400'000);
    EXPECT_FALSE(c.add(phone + kTrueOffset + delay, phone));
    // Never later than the reception: offset <= d for the newest reading.
    EXPECT_LE(c.offset_us(), kTrueOffset + delay);
  }
  EXPECT_EQ(c.resets(), 0);
  // The least delay of the last 10 s of 100 Hz readings is the 3 ms floor plus a few us.
  EXPECT_GE(c.offset_us(), kTrueOffset + 3'000);
  EXPECT_LE(c.offset_us(), kTrueOffset + 3'500);
}

TEST(ClockOffset, FollowsDriftWithinWindowTimesRate) {
  // The phone's clock runs 50 ppm slow: d grows 50 us per second.
  ClockOffset c;
  for (int64_t k = 0; k <= 6000; ++k) {
    const int64_t host = kHost0 + k * 10'000;
    const int64_t phone = host - kTrueOffset - k * 10'000 * 50 / 1'000'000 - 2'000;
    c.add(host, phone);
  }
  const int64_t now_d = kTrueOffset + 60 * 50 + 2'000;
  EXPECT_LE(now_d - c.offset_us(), 10 * 50 + 50);  // lag at most window x drift (+1 bucket)
  EXPECT_GE(now_d - c.offset_us(), 0);
}

TEST(ClockOffset, AJumpForwardResetsAtOnce) {
  ClockOffset c;
  for (int k = 0; k < 100; ++k) c.add(kHost0 + k * 10'000, kHost0 - kTrueOffset + k * 10'000);
  EXPECT_EQ(c.offset_us(), kTrueOffset);
  // The phone clock is set 1 h forward.
  EXPECT_TRUE(c.add(kHost0 + 1'000'000, kHost0 - kTrueOffset + 1'000'000 + 3'600'000'000));
  EXPECT_EQ(c.offset_us(), kTrueOffset - 3'600'000'000);
  EXPECT_EQ(c.resets(), 1);
}

TEST(ClockOffset, ALateBurstIsNotAJumpButARestartIs) {
  ClockOffset c;  // jump 2 s, confirm 2 s
  int64_t host = kHost0;
  auto phone_of = [](int64_t h) { return h - kTrueOffset; };
  for (int k = 0; k < 100; ++k, host += 10'000) c.add(host, phone_of(host));
  // 1.5 s of readings arrive 3 s late (a Wi-Fi stall), then normal ones again.
  for (int k = 0; k < 150; ++k, host += 10'000) EXPECT_FALSE(c.add(host + 3'000'000, phone_of(host)));
  EXPECT_EQ(c.offset_us(), kTrueOffset);
  for (int k = 0; k < 10; ++k, host += 10'000) c.add(host, phone_of(host));
  EXPECT_EQ(c.resets(), 0);
  // The app restarts: its clock (time since its start) begins again at 0.
  const int64_t restart = host;
  bool reset = false;
  for (int k = 0; k < 300 && !reset; ++k, host += 10'000)
    reset = c.add(host + 5'000 + (k % 3) * 1'000, host - restart);
  EXPECT_TRUE(reset);
  EXPECT_EQ(c.resets(), 1);
  EXPECT_GE(host - restart, 2'000'000);  // confirmed after 2 s, not before
  EXPECT_LE(host - restart, 2'100'000);
  EXPECT_EQ(c.offset_us(), restart + 5'000);  // the least delay of the confirming stretch
}

TEST(ClockOffset, OldMinimaLeaveTheWindow) {
  ClockOffset c;
  c.add(kHost0, kHost0 - kTrueOffset);  // one very fast reading
  for (int k = 1; k <= 1200; ++k)
    c.add(kHost0 + k * 10'000, kHost0 - kTrueOffset + k * 10'000 - 20'000);  // 20 ms later
  EXPECT_EQ(c.offset_us(), kTrueOffset + 20'000);
}

}  // namespace
}  // namespace ips::phone_imu
