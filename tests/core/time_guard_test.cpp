// The time guard: one bad stamp is held and discarded, never the reference; a real jump is
// confirmed by consistent stamps and released in order; a sender back from silence is accepted
// when others went on.
#include "core/time_guard.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace ips {
namespace {

constexpr utime_t kT0 = 1767225600000000;
constexpr utime_t kSec = 1000000;
constexpr utime_t kYear = 365LL * 86400 * kSec;

// Feeds stamps of one or more senders through admit(); records what was used, in order.
struct Fixture {
  TimeGuard guard;
  std::vector<utime_t> used;
  int restarts = 0;
  void feed(const std::string& sender, utime_t t) {
    if (guard.admit(sender, t, [this, sender, t] { feed(sender, t); }, [this] { ++restarts; }))
      used.push_back(t);
  }
};

TEST(TimeGuard, OneFutureStampIsHeldThenDiscardedAndNeverTheReference) {
  for (utime_t offset : {20 * kSec, kYear, -20 * kSec, -kYear}) {
    Fixture f;
    for (int i = 0; i < 10; ++i) f.feed("T1", kT0 + i * 100000);
    f.feed("T1", kT0 + 10 * 100000 + offset);
    for (int i = 11; i < 30; ++i) f.feed("T1", kT0 + i * 100000);
    EXPECT_EQ(f.used.size(), 29u) << offset;
    for (utime_t t : f.used) EXPECT_LT(std::llabs(t - kT0), 3 * kSec) << offset;
    EXPECT_EQ(f.guard.stats().discarded, 1) << offset;
    EXPECT_EQ(f.guard.stats().reanchors, 0) << offset;
    EXPECT_EQ(f.guard.newest(), kT0 + 29 * 100000) << offset;
  }
}

TEST(TimeGuard, AClockThatJumpsIsReanchoredAfterConfirmAndNothingIsLost) {
  for (utime_t jump : {3600 * kSec, -3600 * kSec}) {
    Fixture f;
    for (int i = 0; i < 10; ++i) f.feed("T1", kT0 + i * 100000);
    for (int i = 0; i < 10; ++i) f.feed("T1", kT0 + jump + i * 100000);
    ASSERT_EQ(f.used.size(), 20u) << jump;
    // In order: the held ones are released before the one that confirmed them.
    for (int i = 0; i < 10; ++i) EXPECT_EQ(f.used[10 + i], kT0 + jump + i * 100000) << jump;
    EXPECT_EQ(f.guard.stats().reanchors, 1);
    EXPECT_EQ(f.guard.stats().released, 2);
    EXPECT_EQ(f.guard.stats().discarded, 0);
    EXPECT_EQ(f.restarts, jump < 0 ? 1 : 0);
    EXPECT_EQ(f.guard.newest(), kT0 + jump + 9 * 100000);
  }
}

TEST(TimeGuard, ASenderBackFromSilenceIsTakenAtOnceWhileOthersWentOn) {
  Fixture f;
  for (int i = 0; i < 100; ++i) {
    if (i < 10 || i >= 90) f.feed("T1", kT0 + i * 100000);
    f.feed("T2", kT0 + i * 100000 + 50000);
  }
  EXPECT_EQ(f.used.size(), 120u);
  EXPECT_EQ(f.guard.stats().held, 0);
  // Alone, the same silence costs the latency of `confirm` messages, not a message.
  Fixture alone;
  for (int i = 0; i < 100; ++i)
    if (i < 10 || i >= 90) alone.feed("T1", kT0 + i * 100000);
  EXPECT_EQ(alone.used.size(), 20u);
  EXPECT_EQ(alone.guard.stats().reanchors, 1);
}

TEST(TimeGuard, ANewSenderFarFromEveryoneWaitsForConfirmation) {
  Fixture f;
  for (int i = 0; i < 10; ++i) f.feed("T1", kT0 + i * 100000);
  f.feed("X", kT0 + kYear);  // a random id with a random stamp: held, never used
  EXPECT_EQ(f.used.size(), 10u);
  EXPECT_EQ(f.guard.pending(), 1);
  for (int i = 10; i < 20; ++i) f.feed("T2", kT0 + i * 100000);  // new, and near everyone
  EXPECT_EQ(f.used.size(), 20u);
  EXPECT_EQ(f.guard.newest(), kT0 + 19 * 100000);
}

TEST(TimeGuard, ABogusFirstStampOfAllIsOutvotedByTheRealTimeline) {
  Fixture f;
  f.feed("X", kT0 + kYear);
  for (int i = 0; i < 10; ++i) f.feed("T1", kT0 + i * 100000);
  EXPECT_EQ(f.used.size(), 11u);  // the bogus one went through (nothing to judge it by) ...
  EXPECT_EQ(f.guard.newest(), kT0 + 9 * 100000);  // ... but is not the reference any more
  for (int i = 0; i < 10; ++i) f.feed("T2", kT0 + i * 100000);
  EXPECT_EQ(f.used.size(), 21u);
  EXPECT_EQ(f.guard.stats().held, 2);  // only T1's first two waited
}

TEST(TimeGuard, RandomStampsNeverMoveTheReference) {
  Fixture f;
  uint64_t x = 88172645463325252ULL;
  for (int i = 0; i < 1000; ++i) {
    f.feed("T1", kT0 + i * 100000);
    x ^= x << 13;
    x ^= x >> 7;
    x ^= x << 17;
    f.feed("T1", static_cast<utime_t>(x % (100 * static_cast<uint64_t>(kYear))) + 1);
  }
  EXPECT_EQ(f.guard.newest(), kT0 + 999 * 100000);
  EXPECT_EQ(f.guard.stats().reanchors, 0);
  EXPECT_GE(f.used.size(), 1000u);
  EXPECT_LE(f.used.size(), 1010u);  // a random stamp that happens to land in the window
}

TEST(TimeGuard, SlowSendersAreTakenOneIntervalAheadAndStillGuarded) {
  // Three barometers read together at 1.7 Hz (one row of a file every 0.58 s): the next row is
  // more than max_ahead_s ahead of everyone's newest, and still every reading is taken.
  Fixture f;
  for (int i = 0; i < 50; ++i)
    for (const char* id : {"T1", "T1.start", "mpl"}) f.feed(id, kT0 + i * 575931);
  EXPECT_EQ(f.used.size(), 150u);
  EXPECT_EQ(f.guard.stats().held, 0);
  // A 1 Hz anchor: one stamp 20 s ahead is still held and dropped.
  Fixture a;
  for (int i = 0; i < 20; ++i) a.feed("B1", kT0 + i * kSec);
  a.feed("B1", kT0 + 40 * kSec);
  for (int i = 20; i < 30; ++i) a.feed("B1", kT0 + i * kSec);
  EXPECT_EQ(a.used.size(), 30u);
  EXPECT_EQ(a.guard.stats().discarded, 1);
}

TEST(TimeGuard, SendersAreBounded) {
  TimeGuardParams p;
  p.max_senders = 8;
  TimeGuard g(p);
  int used = 0;
  for (int i = 0; i < 100; ++i)
    used += g.admit("S" + std::to_string(i), kT0 + i * 1000, [] {}, [] {});
  EXPECT_EQ(used, 100);
}

}  // namespace
}  // namespace ips
