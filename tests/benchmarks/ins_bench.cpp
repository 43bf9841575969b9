// Google Benchmark: one IMU sample through the foot INS (estimators/ins/), at 200 Hz on a
// foot-mounted IMU (001's rate):
//  - a swing sample: strapdown mechanisation and the 9-state covariance propagation;
//  - a stance sample: the same plus the SHOE detector's window and a zero-velocity update;
//  - the strapdown filter's propagate() alone.
// Run: build/release/bin/ips-bench --benchmark_filter=Ins
#include <benchmark/benchmark.h>

#include <Eigen/Geometry>
#include <cmath>
#include <ips/imu_t.hpp>
#include <limits>

#include "estimators/ins/ins_estimator.hpp"
#include "estimators/ins/strapdown_filter.hpp"

namespace {

constexpr int64_t kT0 = 1767225600000000;
constexpr int64_t kPeriodUs = 5000;

ips::imu_t make_sample(int64_t k, bool swing) {
  ips::imu_t m;
  m.utime = kT0 + k * kPeriodUs;
  m.source = "bench";
  m.device_id = "F1";
  m.device_utime = -1;
  const double s = std::sin(0.05 * static_cast<double>(k));
  m.accel[0] = swing ? 3.0 * s : 0.0;
  m.accel[1] = swing ? 8.0 * s : 0.0;
  m.accel[2] = 9.81 + (swing ? 2.0 * s : 0.0);
  m.gyro[0] = swing ? 5.0 * s : 0.0;
  m.gyro[1] = 0.0;
  m.gyro[2] = 0.0;
  for (double& v : m.mag_ut) v = std::numeric_limits<double>::quiet_NaN();
  return m;
}

void BM_InsSample(benchmark::State& state, bool swing) {
  ips::ins::InsEstimator est([](const ips::pose_t& p) { benchmark::DoNotOptimize(p.position); });
  est.set_site(ips::parse_site_text(
      "name: bench\nanchors: []\n"
      "tags: [{id: F1, start_position: [0, 0, 0], start_heading_deg: 0}]\n"
      "estimators: {ins: {alignment_s: 0.1}}\n",
      "bench"));
  int64_t k = 0;
  for (; k < 100; ++k) est.on_imu(make_sample(k, false));  // aligned
  for (auto _ : state) {
    ips::imu_t m = make_sample(k, swing);
    ++k;
    est.on_imu(m);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK_CAPTURE(BM_InsSample, swing, true);
BENCHMARK_CAPTURE(BM_InsSample, stance, false);

void BM_InsPropagate(benchmark::State& state) {
  ips::ins::StrapdownFilter f;
  f.reset(Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero(),
          ips::ins::ErrorCov::Identity() * 1e-4);
  const Eigen::Vector3d acc(1.0, 2.0, 9.81), rate(0.5, -0.2, 0.1);
  for (auto _ : state) {
    f.propagate(acc, rate, 0.005, 9.81, 0.5, 0.01);
    benchmark::DoNotOptimize(f.position());
  }
}
BENCHMARK(BM_InsPropagate);

}  // namespace
