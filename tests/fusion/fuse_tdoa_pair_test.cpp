// ips-fuse on pairwise TDoA alone (UWB_TDOA, models/tdoa_pair.hpp): loco-tdoa (8 Loco anchors,
// TDoA2 pairs at 100 Hz, 0.05 m noise, anchor L3 1 m short) through FuseEstimator::on_pair; the
// hosted pair tracker's first pose starts the track, then every pair is a tightly coupled update.
#include <gtest/gtest.h>

#include <cstdio>

#include "drivers/sim/scenario.hpp"
#include "fusion/fuse_estimator.hpp"
#include "loggers/eval/evaluation.hpp"
#include "tests/estimators/simulated_inputs.hpp"

namespace ips::fusion {
namespace {

TEST(FuseTdoaPairs, LocoTdoaFromPairsAlone) {
  const sim::Scenario sc = sim::load_scenario("loco-tdoa");
  eval::Evaluator ev;
  FuseEstimator fuse([&](const pose_t& p) {
    if (p.utime - test::kSimStart >= s_to_utime(1.0)) ev.add_estimate("POSE_FUSED", p);
  });
  fuse.set_site(sc.site);
  test::run_simulated(sc, 1,
                      {.truth = [&](const pose_t& m) { ev.add_truth(m); },
                       .uwb_tdoa = [&](const uwb_tdoa_t& m) { fuse.on_pair(m); }});
  const auto rows = ev.rows();
  ASSERT_EQ(rows.size(), 1u);
  const FuseStats& s = fuse.stats();
  std::printf("loco-tdoa seed 1 through ips-fuse: poses %zu rmse_h %.3f p95_h %.3f max_h %.3f; "
              "pair updates used %lld refused %lld\n",
              rows[0].count, rows[0].rmse_h, rows[0].p95_h, rows[0].max_h,
              static_cast<long long>(s.tdoa_epochs_used),
              static_cast<long long>(s.tdoa_epochs_rejected));
  EXPECT_GT(rows[0].count, 500u);
  EXPECT_LE(rows[0].rmse_h, 0.15);
  // L3's two pairs in 8 are refused, the others used.
  EXPECT_GT(s.tdoa_epochs_used, 4000);
  EXPECT_GT(s.tdoa_epochs_rejected, 1200);
  EXPECT_LT(s.tdoa_epochs_rejected, 2000);
}

}  // namespace
}  // namespace ips::fusion
