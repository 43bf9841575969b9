// ips-view's per-update work: a pose into the model through the feed, and the snapshot the page
// gets at every update (the JSON without trails plus the SVG map), for 10 tags on 7 channels
// with full 200-point trails (70 tracks).
#include <benchmark/benchmark.h>

#include <cmath>
#include <ips/pose_t.hpp>
#include <vector>

#include "viewer-headless/bus_feed.hpp"
#include "viewer-headless/svg_render.hpp"
#include "viewer-headless/view_model.hpp"

namespace {

constexpr ips::utime_t kT0 = 1'700'000'000'000'000;
const char* const kChannels[] = {"TRUTH",    "POSE_UWB", "POSE_TDOA", "POSE_AOA",
                                  "POSE_PDR", "INS_MODULE", "POSE_FUSED"};

ips::pose_t pose(int tag, double t) {
  ips::pose_t p{};
  p.utime = kT0 + static_cast<int64_t>(t * 1e6);
  p.source = "bench";
  p.tag_id = "T" + std::to_string(tag);
  p.position[0] = 5 + 3 * std::cos(t + tag);
  p.position[1] = 4 + 3 * std::sin(t + tag);
  p.position[2] = 1.2;
  p.position_cov[0] = 0.01, p.position_cov[4] = 0.02, p.position_cov[8] = 0.05;
  p.status = ips::pose_t::STATUS_OK;
  return p;
}

std::vector<uint8_t> encoded(const ips::pose_t& p) {
  std::vector<uint8_t> b(static_cast<size_t>(p.getEncodedSize()));
  p.encode(b.data(), 0, static_cast<int>(b.size()));
  return b;
}

// 70 tracks with full trails.
void fill(ips::view::ViewModel& m) {
  for (int k = 0; k < 200; ++k)
    for (int tag = 0; tag < 10; ++tag)
      for (const char* ch : kChannels) m.on_pose(ch, pose(tag, k * 0.1), kT0 + k * 100'000);
}

void BM_ViewFeedPose(benchmark::State& state) {
  ips::view::ViewModel m;
  ips::view::BusFeed feed(m, {});
  const auto bytes = encoded(pose(1, 0.5));
  int64_t t = kT0;
  for (auto _ : state) feed.feed("POSE_FUSED", bytes.data(), bytes.size(), t += 1000);
}
BENCHMARK(BM_ViewFeedPose)->Name("ips-view/pose through the feed");

void BM_ViewUpdate(benchmark::State& state) {
  ips::view::ViewModel m;
  fill(m);
  size_t bytes = 0;
  for (auto _ : state) {
    const std::string json = m.json(kT0 + 20'000'000, false);
    const std::string svg = ips::view::render_svg(m);
    bytes = json.size() + svg.size();
    benchmark::DoNotOptimize(bytes);
  }
  state.counters["bytes"] = static_cast<double>(bytes);
}
BENCHMARK(BM_ViewUpdate)->Name("ips-view/update: JSON + SVG, 70 tracks with trails")
    ->Unit(benchmark::kMillisecond);

}  // namespace
