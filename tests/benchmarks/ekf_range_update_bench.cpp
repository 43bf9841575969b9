// Google Benchmark: one constant-velocity predict plus one range update (the TWR tracker's hot
// path), 2D (4 states) and 3D (6 states), against a hand-written fixed-size Eigen 4-state
// predict plus range update without gating or down-weighting (issue 6's yardstick: ours should
// be within 3x of it). Run: build/release/bin/ips-bench --benchmark_filter=range
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
// The yardstick: F P F' + Q and a plain scalar Kalman update, nothing else.
void BM_HandWrittenReference(benchmark::State& state) {
  Eigen::Vector4d x(3.0, 4.0, 0.0, 0.0);
  Eigen::Matrix4d P = Eigen::Matrix4d::Identity() * 0.1;
  const Eigen::Vector3d anchors[4] = {{0, 0, 2.4}, {10, 0, 2.4}, {10, 8, 2.4}, {0, 8, 2.4}};
  const double dt = 0.025, q = 0.5;
  Eigen::Matrix4d F = Eigen::Matrix4d::Identity();
  F(0, 2) = F(1, 3) = dt;
  Eigen::Matrix4d Q = Eigen::Matrix4d::Zero();
  Q(0, 0) = Q(1, 1) = q * dt * dt * dt / 3;
  Q(0, 2) = Q(2, 0) = Q(1, 3) = Q(3, 1) = q * dt * dt / 2;
  Q(2, 2) = Q(3, 3) = q * dt;
  int i = 0;
  for (auto _ : state) {
    const Eigen::Vector3d& a = anchors[i++ & 3];
    x = F * x;
    P = F * P * F.transpose() + Q;
    const Eigen::Vector3d d(x(0) - a.x(), x(1) - a.y(), 1.2 - a.z());
    const double pred = d.norm();
    const Eigen::RowVector4d H(d.x() / pred, d.y() / pred, 0, 0);
    const double S = H * P * H.transpose() + 0.01;
    const Eigen::Vector4d K = P * H.transpose() / S;
    x += K * (pred + 0.01 - pred);
    P = (Eigen::Matrix4d::Identity() - K * H) * P;
    benchmark::DoNotOptimize(x);
    benchmark::DoNotOptimize(P);
  }
}
BENCHMARK(BM_HandWrittenReference)->Name("predict+range_update/hand-written 4-state reference");

BENCHMARK(BM_PredictRangeUpdate<2>)->Name("predict+range_update/2D(4 states)");
BENCHMARK(BM_PredictRangeUpdate<3>)->Name("predict+range_update/3D(6 states)");

}  // namespace
