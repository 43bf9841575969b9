// Google Benchmark: the AoA estimator's hot paths (estimators/aoa/), on the hall of source 000
// (four XPLR-AOA anchors, tag at T1):
//  - one per-epoch solve of four azimuths: bearing lines, Gauss-Newton, Levenberg-Marquardt
//    (warm-started from 20 cm off, as from the previous epoch) and 3D LM with elevations;
//  - one whole advertisement through AoaEstimator::on_event, EKF and per-epoch LM: four events
//    grouped into an epoch, corrected, duplicates resolved, solved or filtered, published.
//  - the epoch grouping alone (epoch_grouper.hpp) with 10 tags advertising at 10 Hz to four
//    anchors, interleaved: the plumbing every event goes through whatever the tracker.
// Run: build/release/bin/ips-bench --benchmark_filter=aoa
#include <benchmark/benchmark.h>

#include <array>
#include <cmath>
#include <ips/ble_aoa_t.hpp>
#include <string>
#include <vector>

#include "core/geometry.hpp"
#include "estimators/aoa/aoa_estimator.hpp"
#include "estimators/aoa/aoa_solvers.hpp"
#include "estimators/aoa/epoch_grouper.hpp"
#include "estimators/aoa/models/aoa_bearing.hpp"

namespace {

using namespace ips::aoa;

const char* kHallSite = R"(
name: aoa-hall
anchors:
  - {id: A1, kind: ble_aoa, position: [0.000, 0.000, 1.683], orientation_deg: [0, 0, 60.73]}
  - {id: A2, kind: ble_aoa, position: [4.552, -0.119, 1.627], orientation_deg: [0, 0, 119.27]}
  - {id: A3, kind: ble_aoa, position: [-0.105, 8.126, 1.723], orientation_deg: [0, 0, -60.73]}
  - {id: A4, kind: ble_aoa, position: [4.651, 8.103, 1.681], orientation_deg: [0, 0, -119.27]}
tags:
  - {id: T1, height_m: 1.528}
)";

const Eigen::Vector3d kT1(2.186, 3.369, 1.528);
// A few degrees of error per anchor, so the iterative solvers have work to do.
constexpr std::array<double, 4> kErrDeg{2.0, -3.0, 1.5, -1.0};

std::array<AnchorFrame, 4> frames(const ips::Site& site) {
  std::array<AnchorFrame, 4> f;
  for (size_t i = 0; i < 4; ++i) f[i] = anchor_frame(site.anchors[i]);
  return f;
}

void BM_AoaSolve(benchmark::State& state, AoaSolver solver, bool three_d) {
  const ips::Site site = ips::parse_site_text(kHallSite, "bench");
  const auto f = frames(site);
  std::vector<BearingObservation> obs;
  for (size_t i = 0; i < 4; ++i) {
    BearingObservation o;
    o.frame = &f[i];
    o.azimuth_rad = predict_angle(f[i], kT1, AngleKind::kAzimuth).angle_rad +
                    ips::deg_to_rad(kErrDeg[i]);
    o.elevation_rad = predict_angle(f[i], kT1, AngleKind::kElevation).angle_rad;
    obs.push_back(o);
  }
  AoaSolveOptions o;
  o.solver = solver;
  o.three_d = three_d;
  o.height_m = kT1.z();
  if (solver != AoaSolver::kBearingLines) o.initial = kT1 + Eigen::Vector3d(0.2, -0.1, 0.0);
  for (auto _ : state) {
    AoaSolution s = solve_aoa(obs, o);
    benchmark::DoNotOptimize(s);
  }
}
BENCHMARK_CAPTURE(BM_AoaSolve, bearing_lines, AoaSolver::kBearingLines, false)
    ->Name("aoa solve/bearing_lines 2D, 4 anchors");
BENCHMARK_CAPTURE(BM_AoaSolve, gauss_newton, AoaSolver::kGaussNewton, false)
    ->Name("aoa solve/gauss_newton 2D, 4 anchors");
BENCHMARK_CAPTURE(BM_AoaSolve, lm, AoaSolver::kLevenbergMarquardt, false)
    ->Name("aoa solve/lm 2D, 4 anchors");
BENCHMARK_CAPTURE(BM_AoaSolve, lm3, AoaSolver::kLevenbergMarquardt, true)
    ->Name("aoa solve/lm 3D (azimuth+elevation), 4 anchors");

void BM_AoaAdvertisement(benchmark::State& state, bool ekf) {
  const ips::Site site = ips::parse_site_text(kHallSite, "bench");
  const auto f = frames(site);
  int64_t poses = 0;
  AoaEstimator est([&](const ips::pose_t&) { ++poses; });
  if (!ekf) est.override_method(AoaMethod::kPerEpoch);
  est.set_site(site);
  std::array<ips::ble_aoa_t, 4> events;
  for (size_t i = 0; i < 4; ++i) {
    ips::ble_aoa_t& m = events[i];
    m.source = "bench";
    m.anchor_id = site.anchors[i].id;
    m.tag_id = "T1";
    m.elevation_deg = 0;
    m.rssi_dbm = -60;
    m.channel = 37;
    m.anchor_uptime_ms = 0;
    m.seq = 0;
  }
  int64_t t = 1767225600000000;
  int k = 0;
  for (auto _ : state) {
    for (size_t i = 0; i < 4; ++i) {
      // The same point with an error that changes from advertisement to advertisement.
      const double wobble = kErrDeg[(i + k) & 3];
      events[i].azimuth_deg = static_cast<float>(
          ips::rad_to_deg(predict_angle(f[i], kT1, AngleKind::kAzimuth).angle_rad) + wobble);
      events[i].utime = t + 5000 * static_cast<int64_t>(i);
      est.on_event(events[i]);
    }
    t += 100000;
    ++k;
  }
  state.counters["poses"] = static_cast<double>(poses);
}
BENCHMARK_CAPTURE(BM_AoaAdvertisement, ekf, true)
    ->Name("aoa advertisement through AoaEstimator/EKF, 4 anchors");
BENCHMARK_CAPTURE(BM_AoaAdvertisement, lm, false)
    ->Name("aoa advertisement through AoaEstimator/per-epoch LM, 4 anchors");

}  // namespace

// Items are events. Each tag's four events 5 ms apart, the tags 10 ms apart, every 100 ms.
void BM_AoaEpochGrouping(benchmark::State& state) {
  constexpr int kTags = 10;
  int64_t epochs = 0, grouped = 0;
  EpochGrouper grouper(0.06, [&](Epoch& e) {
    ++epochs;
    grouped += static_cast<int64_t>(e.events.size());
  });
  std::array<std::string, kTags> tags;
  for (int k = 0; k < kTags; ++k) tags[static_cast<size_t>(k)] = "T" + std::to_string(k + 1);
  AoaEvent e;
  e.azimuth_deg = 10;
  e.rssi_dbm = -60;
  int64_t t = 1767225600000000;
  for (auto _ : state) {
    for (int k = 0; k < kTags; ++k) {
      for (size_t a = 0; a < 4; ++a) {
        e.utime = t + 10000 * k + 5000 * static_cast<int64_t>(a);
        e.anchor = a;
        ++e.order;
        grouper.add(tags[static_cast<size_t>(k)], e);
      }
    }
    t += 100000;
  }
  state.SetItemsProcessed(state.iterations() * kTags * 4);
  state.counters["epochs"] = static_cast<double>(epochs);
  benchmark::DoNotOptimize(grouped);
}
BENCHMARK(BM_AoaEpochGrouping)->Name("aoa epoch grouping, 10 tags x 4 anchors");
