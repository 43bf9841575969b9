// Google Benchmark: barometer readings through the altitude estimator (estimators/altitude/), at
// 003's 10 Hz per sensor: one reference and one tag reading per iteration (the reference series,
// the time alignment, the hypsometric measurement update and the floor detector).
// Run: build/release/bin/ips-bench --benchmark_filter=Altitude
#include <benchmark/benchmark.h>

#include <cmath>
#include <ips/baro_t.hpp>
#include <limits>

#include "estimators/altitude/altitude_estimator.hpp"

namespace {

constexpr int64_t kT0 = 1767225600000000;

ips::baro_t make_reading(const char* id, int64_t t, double p, bool reference) {
  ips::baro_t m;
  m.utime = t;
  m.source = "bench";
  m.sensor_id = id;
  m.pressure_pa = p;
  m.temperature_c = 21.0;
  m.humidity_pct = std::numeric_limits<double>::quiet_NaN();
  m.is_reference = reference;
  m.known_height_m = reference ? 2.4 : std::numeric_limits<double>::quiet_NaN();
  return m;
}

void BM_AltitudeReadingPair(benchmark::State& state) {
  int64_t published = 0;
  ips::altitude::AltitudeEstimator est([&](const ips::altitude_t& a) {
    benchmark::DoNotOptimize(a.height_m);
    ++published;
  });
  est.set_site(ips::parse_site_text(
      "name: bench\nanchors: []\nbaro_stations: [{id: B1, position: [0, 0, 2.4]}]\n"
      "tags: [{id: T1}]\nestimators: {altitude: {offsets_pa: {T1: 25}, floors: {heights_m: "
      "[0, 3.5, 7]}}}\n",
      "bench"));
  int64_t k = 0;
  for (auto _ : state) {
    const int64_t t = kT0 + k * 100000;
    const double noise = 0.2 * std::sin(0.7 * static_cast<double>(k));
    est.on_baro(make_reading("B1", t, 100900.0 + noise, true));
    est.on_baro(make_reading("T1", t + 40000, 100917.0 - noise, false));
    ++k;
  }
  state.SetItemsProcessed(2 * state.iterations());
  state.counters["published"] = static_cast<double>(published);
}
BENCHMARK(BM_AltitudeReadingPair);

}  // namespace
