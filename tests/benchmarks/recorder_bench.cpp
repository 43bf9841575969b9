// Google Benchmark: ips-record's path from the receiving thread to the file, on the `lab`
// scenario's message mix (10 tags): offer() every event, then stop() (which writes all, syncs
// and writes the sidecar). Reports events/s and bytes/s. Run: build/release/bin/ips-bench
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <filesystem>

#include "drivers/sim/simulator.hpp"
#include "loggers/record/recorder.hpp"

namespace {

void BM_RecordLab(benchmark::State& state) {
  ips::sim::Scenario sc = ips::sim::load_scenario("lab");
  sc.duration_s = 60;
  ips::sim::replicate_walkers(sc, 10);
  ips::sim::Simulator sim(sc, 1, 1767225600000000);
  std::vector<ips::record::Event> events;
  ips::sim::SimEvent e;
  int64_t bytes = 0;
  while (sim.next(e)) {
    events.push_back({e.kind, e.utime, e.data});
    bytes += static_cast<int64_t>(e.data.size());
  }
  char tmpl[] = "/tmp/ips-record-bench-XXXXXX";
  const std::filesystem::path dir = mkdtemp(tmpl);
  for (auto _ : state) {
    ips::record::RecorderOptions ro;
    ro.session.out = dir / "bench.lcm";
    ro.session.force = true;
    ro.queue_bytes = size_t{1} << 30;  // measure the writer, not drops
    ips::record::Recorder r(ro);
    for (const auto& ev : events) r.offer(ev.channel, ev.utime, ev.data.data(), ev.data.size());
    r.stop("benchmark");
    if (r.stats().written < static_cast<int64_t>(events.size()))  // (+ the SITE head)
      state.SkipWithError(("written " + std::to_string(r.stats().written) + " of " +
                           std::to_string(events.size()) + ", dropped " +
                           std::to_string(r.stats().dropped))
                              .c_str());
  }
  std::filesystem::remove_all(dir);
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(events.size()));
  state.SetBytesProcessed(state.iterations() * bytes);
  state.counters["events"] = static_cast<double>(events.size());
}
BENCHMARK(BM_RecordLab)->Name("ips-record/lab 60 s, 10 tags")->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
