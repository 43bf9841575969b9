// Google Benchmark: ips-pdr's hot path, one IMU sample through PdrEstimator::on_imu while walking
// (attitude EKF prediction, gravity update, a magnetometer update every 0.5 s, the 9th-order
// Butterworth and the step detector; a step every ~55 samples at 100 Hz), and the Butterworth
// filter alone.
// Run: build/release/bin/ips-bench --benchmark_filter=pdr
#include <benchmark/benchmark.h>

#include <cmath>
#include <ips/imu_t.hpp>

#include "estimators/pdr/butterworth.hpp"
#include "estimators/pdr/pdr_estimator.hpp"

namespace {

void BM_PdrImuSample(benchmark::State& state) {
  int64_t steps = 0;
  ips::pdr::PdrEstimator est([&](const ips::step_t&) { ++steps; }, [](const ips::pose_t&) {});
  est.set_site(ips::parse_site_text(
      "name: s\nanchors: []\ntags:\n  - {id: P1, height_m: 1.1, start_position: [0, 0]}\n", "s"));
  const ips::pdr::EarthField field;
  const Eigen::Vector3d mag = field.world();  // a flat phone, top to the north
  ips::imu_t m{};
  m.device_id = "P1";
  m.device_utime = -1;
  int64_t i = 0;
  auto sample = [&] {
    const double t = static_cast<double>(i) * 0.01;
    const double walk = t > 2.0 ? 2.87 * std::sin(2 * M_PI * 1.8 * t) : 0.0;
    m.utime = 1767225600000000 + i * 10000;
    m.accel[0] = 0;
    m.accel[1] = 0;
    m.accel[2] = 9.81 + walk;
    for (int k = 0; k < 3; ++k) {
      m.gyro[k] = 0.001;
      m.mag_ut[k] = mag(k);
    }
    est.on_imu(m);
    ++i;
  };
  for (int k = 0; k < 300; ++k) sample();  // rest and alignment first
  for (auto _ : state) sample();
  state.counters["steps"] = static_cast<double>(steps);
}
BENCHMARK(BM_PdrImuSample)->Name("pdr imu sample through PdrEstimator (walking, 100 Hz)");

void BM_Butterworth9(benchmark::State& state) {
  ips::pdr::ButterworthLowPass lp(9, 3.0, 400.0);
  double x = 0;
  for (auto _ : state) {
    x += 0.01;
    benchmark::DoNotOptimize(lp.step(std::sin(x)));
  }
}
BENCHMARK(BM_Butterworth9)->Name("pdr butterworth 9th order, one sample");

}  // namespace
