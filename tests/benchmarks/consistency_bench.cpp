// Google Benchmark: one range's innovation through the consistency monitor
// (core/consistency.hpp), as ips-uwb-twr and ips-fuse add one per range: 8 anchors in turn, each
// heard 100 times a second (10 tags at 10 Hz), so that every channel's window is full (300
// samples) and every add moves the sorted windows, relearns every 5 and checks every 10 samples.
// The per-sample cost of the monitors is 10 % of ips-replay's time (docs/development.md).
// Run: build/release/bin/ips-bench --benchmark_filter=Consistency
#include <benchmark/benchmark.h>

#include <array>
#include <random>
#include <string>

#include "core/consistency.hpp"

namespace {

void BM_ConsistencyRangeSample(benchmark::State& state) {
  ips::ConsistencyMonitor monitor;
  const std::array<std::string, 8> anchors = {"A1", "A2", "A3", "A4", "A5", "A6", "A7", "A8"};
  const std::string setting = ips::setting_text("range_sigma_m", 0.1);
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.1);
  // Innovations drawn ahead, so that the generator is not timed.
  std::array<double, 4096> r{};
  for (double& x : r) x = noise(rng);
  double t = 0.0;
  size_t i = 0;
  for (auto _ : state) {
    const size_t k = i % anchors.size();
    monitor.add_scalar("RANGE", anchors[k], t, r[i % r.size()], 0.002, 0.01, false, setting);
    benchmark::DoNotOptimize(monitor.variance("RANGE", anchors[k], 0.01));
    t += 0.00125;  // 800 ranges a second
    ++i;
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["channels"] = static_cast<double>(monitor.channels());
}
BENCHMARK(BM_ConsistencyRangeSample);

}  // namespace
