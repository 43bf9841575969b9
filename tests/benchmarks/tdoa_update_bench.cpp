// Google Benchmark: the TDoA tracker's hot paths (estimators/uwb_tdoa/).
//  - predict + one scalar TDoA update (models/tdoa.hpp), 2D (4 states) and 3D (6 states);
//  - one epoch's differences in one vector update with the shared-reference covariance, 3 and 5
//    differences (4 and 6 anchors);
//  - a whole blink through TdoaEstimator::on_rx: 4 and 6 anchors' reports grouped, converted to
//    master time with the clock estimates, gated, applied and published (with the sync rounds
//    that keep the clocks, one every 20 blinks, included).
// Run: build/release/bin/ips-bench --benchmark_filter=tdoa
#include <benchmark/benchmark.h>

#include <array>
#include <cmath>
#include <string>
#include <vector>

#include "estimators/uwb_tdoa/models/tdoa.hpp"
#include "estimators/uwb_tdoa/tdoa_estimator.hpp"
#include "tests/estimators/uwb_tdoa/exact_network.hpp"

namespace {

using ips::CvFilter;

const Eigen::Vector3d kAnchors[6] = {{0, 0, 2.5}, {10, 0, 2.5}, {10, 8, 2.5},
                                     {0, 8, 2.5}, {5, 0, 2.2},  {5, 8, 2.2}};

template <int D>
CvFilter<D> tracking_filter() {
  CvFilter<D> f;
  f.x.setZero();
  f.x(0) = 3.0;
  f.x(1) = 4.0;
  if (D == 3) f.x(2) = 1.2;
  f.P = ips::Mat<2 * D>::Identity() * 0.01;
  return f;
}

template <int D>
void BM_PredictTdoaUpdate(benchmark::State& state) {
  CvFilter<D> f = tracking_filter<D>();
  int i = 0;
  double innovation = 0;
  const double r_var = 2 * 0.051 * 0.051;  // two receptions of 0.17 ns
  for (auto _ : state) {
    const Eigen::Vector3d& a = kAnchors[1 + (i++ & 3)];
    f.predict(0.025, 0.5);
    const Eigen::Vector3d p(f.x(0), f.x(1), D == 3 ? f.x(2) : 1.2);
    const double z = (p - a).norm() - (p - kAnchors[0]).norm() + 0.01;
    auto res = ips::uwb_tdoa::tdoa_update<D>(f, 1.2, a, kAnchors[0], z, r_var, 16.0, &innovation);
    benchmark::DoNotOptimize(res);
    benchmark::DoNotOptimize(f.x);
  }
}
BENCHMARK(BM_PredictTdoaUpdate<2>)->Name("tdoa predict+scalar_update/2D(4 states)");
BENCHMARK(BM_PredictTdoaUpdate<3>)->Name("tdoa predict+scalar_update/3D(6 states)");

template <int D>
void BM_PredictTdoaVectorUpdate(benchmark::State& state) {
  const int m = static_cast<int>(state.range(0));
  CvFilter<D> f = tracking_filter<D>();
  std::array<ips::uwb_tdoa::TdoaRow<D>, 5> rows;
  std::array<double, 5> y{}, var{};
  var.fill(0.051 * 0.051);
  for (auto _ : state) {
    f.predict(0.1, 0.5);
    for (int k = 0; k < m; ++k) {
      rows[k] = ips::uwb_tdoa::tdoa_row<D>(f.x, 1.2, kAnchors[k + 1], kAnchors[0]);
      y[k] = 0.01 * (k - 1);
    }
    auto res = ips::uwb_tdoa::tdoa_vector_update<D>(f, rows.data(), y.data(), var.data(),
                                                    0.051 * 0.051, m);
    benchmark::DoNotOptimize(res);
    benchmark::DoNotOptimize(f.x);
  }
  // Seconds per difference (shown with an SI prefix: 150n is 150 ns).
  state.counters["per_difference"] =
      benchmark::Counter(static_cast<double>(m), benchmark::Counter::kIsIterationInvariantRate |
                                                     benchmark::Counter::kInvert);
}
BENCHMARK(BM_PredictTdoaVectorUpdate<2>)->Arg(3)->Arg(5)->Name("tdoa predict+vector_update/2D");
BENCHMARK(BM_PredictTdoaVectorUpdate<3>)->Arg(3)->Arg(5)->Name("tdoa predict+vector_update/3D");

// A whole blink epoch through the estimator: noise-free reports of a tag walking a circle,
// built once per anchor and updated in place (no allocation in the loop).
void BM_EstimatorBlinkEpoch(benchmark::State& state) {
  using ips::uwb_tdoa::test::ExactNetwork;
  const int n = static_cast<int>(state.range(0));
  std::vector<ips::uwb_tdoa::test::TestAnchor> anchors;
  const double offsets[6] = {3.98, 6.52, 16.9, 0.25, 11.0, 8.0};
  const double rates[6] = {12, -31, 44, -7.5, 25, 3};
  for (int i = 0; i < n; ++i)
    anchors.push_back({"A" + std::to_string(i + 1), kAnchors[i], offsets[i], rates[i]});
  const ExactNetwork net(anchors, 0);
  int64_t poses = 0;
  ips::uwb_tdoa::TdoaEstimator est([&](const ips::pose_t&) { ++poses; },
                                   [](const ips::clock_t&) {});
  est.set_site(net.site());
  std::vector<ips::uwb_rx_t> blink, sync;
  net.blink([&](const ips::uwb_rx_t& m) { blink.push_back(m); }, "T1", 0, 0.001, {3, 4, 1.2});
  net.sync([&](const ips::uwb_rx_t& m) { sync.push_back(m); }, 0);
  int32_t k = 0;
  auto step = [&] {
    if (k % 20 == 0) {
      const double ts = 0.1 * k;
      for (size_t i = 0; i < sync.size(); ++i) {
        const int a = static_cast<int>(i);  // the master's record first, then anchors 1..n-1
        const double tof = (kAnchors[a] - kAnchors[0]).norm() / ips::uwb_tdoa::kSpeedOfLightMps;
        sync[i].utime = ips::uwb_tdoa::test::kStart + ips::s_to_utime(ts + 0.002);
        sync[i].seq = k / 20;
        sync[i].rx_counter = net.counter(a, ts + tof);
        est.on_rx(sync[i]);
      }
    }
    const double t = 0.1 * k + 0.001;
    const Eigen::Vector3d p(5 + 2 * std::cos(t / 2), 4 + 2 * std::sin(t / 2), 1.2);
    for (int i = 0; i < n; ++i) {
      blink[i].utime = ips::uwb_tdoa::test::kStart + ips::s_to_utime(t + 0.002);
      blink[i].seq = k;
      blink[i].rx_counter =
          net.counter(i, t + (p - kAnchors[i]).norm() / ips::uwb_tdoa::kSpeedOfLightMps);
      est.on_rx(blink[i]);
    }
    ++k;
  };
  for (int w = 0; w < 100; ++w) step();  // clocks tracking, track initialised
  for (auto _ : state) step();
  if (est.stats().initialisations != 1 || est.stats().rejected_gate != 0)
    state.SkipWithError("the track did not run cleanly");
  state.counters["poses"] = static_cast<double>(poses);
  state.counters["per_difference"] =
      benchmark::Counter(static_cast<double>(n - 1), benchmark::Counter::kIsIterationInvariantRate |
                                                         benchmark::Counter::kInvert);
}
BENCHMARK(BM_EstimatorBlinkEpoch)->Arg(4)->Arg(6)->Name("tdoa estimator blink epoch/anchors");

}  // namespace
