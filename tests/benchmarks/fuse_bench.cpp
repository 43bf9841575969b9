// Google Benchmark: messages through ips-fuse's estimator (fusion/fuse_estimator.hpp), one tag
// walking the lab at 1 m/s: 8 anchors ranging at 10 Hz each and a foot-INS module at 2 Hz, whose
// displacement rolls the track back over the ranges of its half second and fuses them again.
// Items are messages; the time per item is the mean over both kinds, rollbacks included.
// Run: build/release/bin/ips-bench --benchmark_filter=Fuse
#include <benchmark/benchmark.h>

#include <cmath>
#include <string>

#include "fusion/fuse_estimator.hpp"

namespace {

constexpr int64_t kT0 = 1767225600000000;

void BM_FuseMessages(benchmark::State& state) {
  const ips::Site site = ips::parse_site_text(
      "name: bench\nanchors:\n"
      "  - {id: A1, position: [0, 0, 2.4]}\n  - {id: A2, position: [10, 0, 2.4]}\n"
      "  - {id: A3, position: [10, 8, 2.4]}\n  - {id: A4, position: [0, 8, 2.4]}\n"
      "  - {id: A5, position: [5, 0, 2.4]}\n  - {id: A6, position: [10, 4, 2.4]}\n"
      "  - {id: A7, position: [5, 8, 2.4]}\n  - {id: A8, position: [0, 4, 2.4]}\n"
      "tags: [{id: T1, height_m: 1.2}]\n",
      "bench");
  int64_t published = 0;
  ips::fusion::FuseEstimator est([&](const ips::pose_t& p) {
    benchmark::DoNotOptimize(p.position);
    ++published;
  });
  est.set_site(site);
  int64_t k = 0;  // 10 ms slots: a range from anchor (k % 8) every 12.5 ms on average
  ips::uwb_range_t r{};
  r.tag_id = "T1";
  ips::pose_t ins{};
  ins.tag_id = "T1";
  auto where = [](double t) {
    return Eigen::Vector2d(5 + 3 * std::cos(t / 3), 4 + 3 * std::sin(t / 3));
  };
  for (auto _ : state) {
    const double t = 0.0125 * static_cast<double>(k);
    const Eigen::Vector2d p = where(t);
    if (k % 40 == 0) {  // the INS module every 0.5 s
      ins.utime = kT0 + static_cast<int64_t>(t * 1e6);
      ins.position[0] = p.x();
      ins.position[1] = p.y();
      ins.position[2] = 0.1;
      est.on_ins_module(ins);
    } else {
      const ips::Anchor& a = site.anchors[static_cast<size_t>(k % 8)];
      r.utime = kT0 + static_cast<int64_t>(t * 1e6);
      r.anchor_id = a.id;
      r.range_m = (Eigen::Vector3d(p.x(), p.y(), 1.2) - a.position).norm();
      est.on_range(r);
    }
    ++k;
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["published"] = static_cast<double>(published);
  state.counters["rollbacks"] = static_cast<double>(est.stats().rollbacks);
}
BENCHMARK(BM_FuseMessages);

}  // namespace
