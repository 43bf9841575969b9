// EpochGrouper (estimators/aoa/epoch_grouper.hpp): the advertising interval is the median of
// the newest 31 intervals (kept in order as they come and go), the window follows it, and epochs
// close oldest first, ties to the first tag id.
#include "estimators/aoa/epoch_grouper.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <deque>
#include <random>
#include <string>
#include <vector>

namespace ips::aoa {
namespace {

constexpr utime_t kT0 = 1767225600000000;

TEST(EpochGrouper, TheIntervalIsTheMedianOfTheNewest31) {
  EpochGrouper g(0.06, [](Epoch&) {});
  std::mt19937_64 rng(3);
  std::uniform_int_distribution<utime_t> gap(1000, 300000);
  std::deque<utime_t> recent;
  utime_t t = kT0;
  AoaEvent e;
  e.anchor = 2;
  for (int k = 0; k < 500; ++k) {
    const utime_t dt = k % 50 == 49 ? 3'000'000 : gap(rng);  // an outage now and then: not counted
    t += dt;
    e.utime = t;
    g.add("T1", e);
    if (k > 0 && dt < 2'000'000) {
      recent.push_back(dt);
      if (recent.size() > EpochGrouper::kIntervals) recent.pop_front();
    }
    if (recent.size() < EpochGrouper::kMinIntervals) {
      EXPECT_EQ(g.advertising_interval_us("T1"), 0);
      continue;
    }
    std::vector<utime_t> v(recent.begin(), recent.end());
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    ASSERT_EQ(g.advertising_interval_us("T1"), v[v.size() / 2]) << "event " << k;
    EXPECT_EQ(g.window_us("T1"),
              std::min<utime_t>(60000, static_cast<utime_t>(0.8 * static_cast<double>(v[v.size() / 2]))));
  }
  EXPECT_EQ(g.advertising_interval_us("T2"), 0);
  EXPECT_EQ(g.window_us("T2"), 60000);
}

TEST(EpochGrouper, EpochsCloseOldestFirstTiesToTheFirstTagId) {
  std::vector<std::string> closed;
  std::vector<size_t> sizes;
  EpochGrouper g(0.06, [&](Epoch& ep) {
    closed.push_back(ep.tag_id);
    sizes.push_back(ep.events.size());
  });
  AoaEvent e;
  auto add = [&](const std::string& tag, utime_t t, size_t anchor) {
    e.utime = t;
    e.anchor = anchor;
    ++e.order;
    g.add(tag, e);
  };
  add("T3", kT0, 0);
  add("T2", kT0, 0);  // as old as T3's: T2 first
  add("T1", kT0 + 10000, 0);
  add("T3", kT0 + 20000, 1);
  add("T2", kT0 + 30000, 1);
  EXPECT_EQ(g.open_epochs(), 3u);
  add("T9", kT0 + 200000, 0);  // every window has passed
  ASSERT_EQ(closed, (std::vector<std::string>{"T2", "T3", "T1"}));
  EXPECT_EQ(sizes, (std::vector<size_t>{2, 2, 1}));
  g.flush_all();
  ASSERT_EQ(closed.size(), 4u);
  EXPECT_EQ(closed.back(), "T9");
  // The next advertisement of a tag opens a new epoch of its own (the buffer reused).
  add("T2", kT0 + 300000, 3);
  g.flush_all();
  EXPECT_EQ(closed.back(), "T2");
  EXPECT_EQ(sizes.back(), 1u);
}

}  // namespace
}  // namespace ips::aoa
