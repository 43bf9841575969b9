// RecentRepeats: a copy among the last kSize keys is known; an older one, or a reading that
// differs in any part of its key, is not.
#include "core/repeat_filter.hpp"

#include <gtest/gtest.h>

namespace ips {
namespace {

TEST(RecentRepeats, KnowsACopyAmongTheLastKeysOnly) {
  RecentRepeats r;
  const auto key = [](int i) { return repeat_key(1'000'000 + i, i, i % 4, 3.25 + i); };
  for (int i = 0; i < 20; ++i) EXPECT_FALSE(r.repeated(key(i))) << i;
  // The last 16 (4..19) are known; 0..3 were forgotten, and are remembered again when seen.
  for (int i = 19; i >= 4; --i) EXPECT_TRUE(r.repeated(key(i))) << i;
  EXPECT_FALSE(r.repeated(key(0)));
  EXPECT_TRUE(r.repeated(key(0)));
}

TEST(RecentRepeats, EveryPartOfTheKeyCounts) {
  const uint64_t k = repeat_key(1'000'000, 7, 2, 4.5);
  EXPECT_EQ(k, repeat_key(1'000'000, 7, 2, 4.5));
  EXPECT_NE(k, repeat_key(1'000'001, 7, 2, 4.5));
  EXPECT_NE(k, repeat_key(1'000'000, 8, 2, 4.5));
  EXPECT_NE(k, repeat_key(1'000'000, 7, 3, 4.5));
  EXPECT_NE(k, repeat_key(1'000'000, 7, 2, 4.5000001));
  EXPECT_NE(k, repeat_key(1'000'000, 2, 7, 4.5));  // the parts' order matters
}

}  // namespace
}  // namespace ips
