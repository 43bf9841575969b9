// Google Benchmark: one constant-velocity predict plus one range update (the TWR tracker's hot
// path), 2D (4 states) and 3D (6 states). Run: build/release/bin/ips-bench
#include <benchmark/benchmark.h>

#include "estimators/uwb_twr/models/uwb_range.hpp"

namespace {

template <int D>
void BM_PredictRangeUpdate(benchmark::State& state) {
  using ips::CvFilter;
  CvFilter<D> f;
  f.x.setZero();
  f.x(0) = 3.0;
  f.x(1) = 4.0;
  f.P = ips::Mat<2 * D>::Identity() * 0.1;
  const Eigen::Vector3d anchors[4] = {{0, 0, 2.4}, {10, 0, 2.4}, {10, 8, 2.4}, {0, 8, 2.4}};
  int i = 0;
  ips::uwb_twr::RangeNoise noise{0.01, 16.0, 6.25, 1.5};
  for (auto _ : state) {
    const Eigen::Vector3d& a = anchors[i++ & 3];
    f.predict(0.025, 0.5);
    Eigen::Vector3d p(f.x(0), f.x(1), D == 3 ? f.x(2) : 1.2);
    const double r = (p - a).norm() + 0.01;
    auto res = ips::uwb_twr::range_update<D>(f, a, 1.2, r, noise);
    benchmark::DoNotOptimize(res);
    benchmark::DoNotOptimize(f.x);
  }
}
BENCHMARK(BM_PredictRangeUpdate<2>)->Name("predict+range_update/2D(4 states)");
BENCHMARK(BM_PredictRangeUpdate<3>)->Name("predict+range_update/3D(6 states)");

}  // namespace
