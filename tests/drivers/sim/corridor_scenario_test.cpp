// The corridor scenarios' data against their own model (001_hybrid_uwb_ins.md Tab. 4.1):
// ranges N(d + 0.11, 0.45) every 0.5 s per enabled anchor, INS_MODULE at 2 Hz.
#include <gtest/gtest.h>

#include <cmath>
#include <ips/pose_t.hpp>
#include <ips/uwb_range_t.hpp>
#include <map>

#include "drivers/sim/simulator.hpp"

namespace ips::sim {
namespace {

constexpr utime_t kStart = 1767225600000000;

TEST(CorridorScenario, RangesHaveTheThesisBiasAndSigmaAndRate) {
  double sum = 0, sum_sq = 0;
  int n = 0, ins = 0;
  std::map<std::string, int> per_anchor;
  for (uint64_t seed = 1; seed <= 5; ++seed) {
    Scenario sc = load_scenario("corridor-8");
    Simulator sim(sc, seed, kStart);
    const Scenario& s = sim.scenario();
    SimEvent e;
    while (sim.next(e)) {
      if (e.kind == "UWB_RANGE") {
        uwb_range_t r;
        r.decode(e.data.data(), 0, static_cast<int>(e.data.size()));
        const Eigen::Vector3d p = s.trajectories[0].path.at(utime_to_s(r.utime - kStart)).position;
        const double err = r.range_m - (p - s.site.find_anchor(r.anchor_id)->position).norm();
        sum += err;
        sum_sq += err * err;
        ++n;
        if (seed == 1) per_anchor[r.anchor_id]++;
      } else if (e.kind == "INS_MODULE" && seed == 1) {
        ++ins;
      }
    }
  }
  const double mean = sum / n, sigma = std::sqrt(sum_sq / n - mean * mean);
  // n ~ 3760: standard error of the mean 0.45/sqrt(n) = 0.007 m; of sigma ~0.005 m.
  EXPECT_NEAR(mean, 0.11, 0.025);
  EXPECT_NEAR(sigma, 0.45, 0.02);
  ASSERT_EQ(per_anchor.size(), 4u);
  for (const auto& [id, count] : per_anchor) EXPECT_NEAR(count, 94 * 2, 2) << id;
  EXPECT_NEAR(ins, 94 * 2, 2);
}

TEST(CorridorScenario, DisabledAnchorsAreNotRanged) {
  Simulator sim(load_scenario("corridor-L-2"), 1, kStart);
  std::map<std::string, int> per_anchor;
  SimEvent e;
  while (sim.next(e))
    if (e.kind == "UWB_RANGE") {
      uwb_range_t r;
      r.decode(e.data.data(), 0, static_cast<int>(e.data.size()));
      per_anchor[r.anchor_id]++;
    }
  EXPECT_EQ(per_anchor.size(), 2u);
  EXPECT_TRUE(per_anchor.count("WR1") && per_anchor.count("WR2"));
}

}  // namespace
}  // namespace ips::sim
