// PoseTally: what a pose_t says about the measurements behind it (num_used, residual_m, status).
#include "core/pose_tally.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace ips {
namespace {

constexpr int32_t kOk = pose_t::STATUS_OK;

TEST(PoseTally, CountsResidualsBetweenPosesAndFlagsARestart) {
  PoseTally t;
  EXPECT_TRUE(t.due(1000, 0.1));  // nothing published yet
  t.restart(4, 0.5);              // the first fix: not a RE-initialisation
  t.add(0.3);
  pose_t p;
  t.finish(p, true, 1000);
  EXPECT_EQ(p.num_used, 5);
  EXPECT_DOUBLE_EQ(p.residual_m, std::sqrt((4 * 0.25 + 0.09) / 5));
  EXPECT_EQ(p.status, kOk | pose_t::STATUS_2D);
  EXPECT_FALSE(t.due(1000 + 99999, 0.1));
  EXPECT_TRUE(t.due(1000 + 100000, 0.1));
  t.finish(p, false, 200000);  // nothing since: coasting, residual unknown
  EXPECT_EQ(p.num_used, 0);
  EXPECT_TRUE(std::isnan(p.residual_m));
  EXPECT_EQ(p.status, kOk | pose_t::STATUS_COASTING);
  t.add_many(2, 0.08);
  t.restart(3, 0.1);  // after a pose: flagged, and the earlier two no longer count
  t.finish(p, false, 300000);
  EXPECT_EQ(p.num_used, 3);
  EXPECT_NEAR(p.residual_m, 0.1, 1e-15);
  EXPECT_EQ(p.status, kOk | pose_t::STATUS_REINITIALISED);
  t.finish(p, false, 400000);  // the flag is for one pose only
  EXPECT_EQ(p.status, kOk | pose_t::STATUS_COASTING);
}

}  // namespace
}  // namespace ips
