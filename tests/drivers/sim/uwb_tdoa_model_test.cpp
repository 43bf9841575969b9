// The UWB TDoA model (drivers/sim/models/uwb_tdoa.cpp): 40-bit counter wrap, blink TDoAs that
// match the geometry once the simulated clocks are removed, sync timing, clock drift, losses,
// walls, determinism and parameter errors. Figures from ../shared/reference/004_uwb_kf.md.
#include <gtest/gtest.h>

#include <cmath>
#include <ips/uwb_rx_t.hpp>
#include <map>
#include <set>

#include "drivers/sim/models/uwb_tdoa.hpp"
#include "drivers/sim/simulator.hpp"

namespace ips::sim {

namespace {

constexpr utime_t kStart = 1767225600000000;
constexpr double kHz = 63.8976e9;
constexpr int64_t kWrap = int64_t{1} << 40;
constexpr double kC = 299792458.0;

// Four uwb_tdoa anchors at the corners of a 10 x 8 m room (and a TWR anchor that must be
// ignored); T1 walks the lab loop at 1 m/s. The uwb_tdoa parameters start on line 16.
std::string scenario_text(const std::string& tdoa_params, double duration_s = 30) {
  return "duration_s: " + std::to_string(duration_s) +
         "\nsite:\n  anchors:\n"
         "    - {id: A1, kind: uwb_tdoa, position: [0, 0, 2.5]}\n"
         "    - {id: A2, kind: uwb_tdoa, position: [10, 0, 2.5]}\n"
         "    - {id: A3, kind: uwb_tdoa, position: [10, 8, 2.5]}\n"
         "    - {id: A4, kind: uwb_tdoa, position: [0, 8, 2.5]}\n"
         "    - {id: U1, kind: uwb, position: [5, 4, 2.5]}\n"
         "  tags:\n    - {id: T1, height_m: 1.2}\n"
         "trajectories:\n  - tag: T1\n"
         "    waypoints: [[2, 1.5], [8, 1.5], [8.5, 4], [7.5, 6.5], [4, 6.5], [1.5, 4.5]]\n"
         "sensors:\n  uwb_tdoa:\n" +
         tdoa_params;
}

struct Rx {
  uwb_rx_t msg;
  std::vector<uint8_t> bytes;
};

std::vector<Rx> run_rx(const Scenario& sc, uint64_t seed) {
  Simulator s(sc, seed, kStart);
  std::vector<Rx> out;
  SimEvent e;
  utime_t last = 0;
  while (s.next(e)) {
    EXPECT_GE(e.utime, last) << "events out of time order";
    last = e.utime;
    if (e.kind != "UWB_RX") continue;
    Rx r;
    r.msg.decode(e.data.data(), 0, static_cast<int>(e.data.size()));
    EXPECT_EQ(r.msg.utime, e.utime);
    r.bytes = e.data;
    out.push_back(std::move(r));
  }
  return out;
}

// x wrapped into [-2^39, 2^39) ticks.
double wrap_ticks(double x) {
  const double w = static_cast<double>(kWrap);
  return x - w * std::floor(x / w + 0.5);
}

std::string config_error(const std::string& text) {
  try {
    parse_scenario_text(text, "my.yaml");
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "no error";
}

TEST(UwbTdoaModel, CounterWrapsAt2To40) {
  // Noise-free clocks with fixed offsets: A2's counter starts 17.0 s in, 0.207 s before the
  // wrap at 2^40 / 63.8976e9 = 17.207 s (004 §4); syncs at t = 0, 2, 4 s from master A1.
  const Scenario sc = parse_scenario_text(
      scenario_text("    master: A1\n    rx_noise_sigma_ns: 0\n    drift_max_ppb: 0\n"
                    "    clocks: {A1: {offset_s: 0}, A2: {offset_s: 17.0}}\n",
                    5),
      "my.yaml");
  std::vector<int64_t> a1, a2;
  for (const Rx& r : run_rx(sc, 1)) {
    EXPECT_GE(r.msg.rx_counter, 0);
    EXPECT_LT(r.msg.rx_counter, kWrap);
    EXPECT_DOUBLE_EQ(r.msg.counter_hz, kHz);
    if (!r.msg.is_sync) continue;
    if (r.msg.anchor_id == "A1") a1.push_back(r.msg.rx_counter);
    if (r.msg.anchor_id == "A2") a2.push_back(r.msg.rx_counter);
  }
  ASSERT_EQ(a1.size(), 3u);
  ASSERT_EQ(a2.size(), 3u);
  // The master's transmit records: exactly 2 s x 63.8976e9 apart, from 0.
  EXPECT_EQ(a1[0], 0);
  EXPECT_EQ(a1[1], 127'795'200'000);
  EXPECT_EQ(a1[2], 255'590'400'000);
  // A2, 10 m away: floor(hz * (t + 17.0 + 10 m / c)), minus 2^40 once past the wrap.
  const double tof_ticks = 10.0 / kC * kHz;  // 2131.4 ticks
  EXPECT_NEAR(static_cast<double>(a2[0]), 17.0 * kHz + tof_ticks, 1.0);
  EXPECT_NEAR(static_cast<double>(a2[1]), 19.0 * kHz + tof_ticks - static_cast<double>(kWrap), 1.0);
  EXPECT_NEAR(static_cast<double>(a2[2]), 21.0 * kHz + tof_ticks - static_cast<double>(kWrap), 1.0);
  EXPECT_LT(a2[1], a2[0]);  // wrapped
}

TEST(UwbTdoaModel, BlinkTdoaMatchesGeometryOnceTheClocksAreRemoved) {
  // sigma 0.2 ns per timestamp, drifting clocks with a rate random walk. For each blink, the
  // counter difference of two anchors minus their true clock offset difference must be the
  // geometric TDoA (d_i - d_j) / c, with sigma sqrt(2 sigma^2 + 2 tick^2 / 12) (floor
  // quantisation). The pairs A2-A1 and A4-A3 share no timestamp, so their errors are independent.
  const double sigma_s = 0.2e-9;
  const Scenario sc = parse_scenario_text(
      scenario_text("    master: A1\n    rx_noise_sigma_ns: 0.2\n    drift_max_ppb: 45\n"
                    "    drift_random_walk_ppb_per_sqrt_s: 0.05\n    report_latency_s: 0.003\n",
                    60),
      "my.yaml");
  const SimWorld world{sc.site, sc.trajectories, 11};
  const YamlField& section = sc.sensor("uwb_tdoa")->section;

  // Blinks by seq: anchor -> counter, and the emission time from utime - latency.
  std::map<int32_t, std::map<std::string, int64_t>> blinks;
  std::map<int32_t, int64_t> emission_us;
  for (const Rx& r : run_rx(sc, 11)) {
    if (r.msg.is_sync) continue;
    EXPECT_EQ(r.msg.sender_id, "T1");
    EXPECT_EQ(r.msg.source, "ips-sim");
    EXPECT_TRUE(std::isnan(r.msg.rx_power_dbm) && std::isnan(r.msg.fp_power_dbm) &&
                std::isnan(r.msg.quality));
    blinks[r.msg.seq][r.msg.anchor_id] = r.msg.rx_counter;
    emission_us[r.msg.seq] = r.msg.utime - kStart - 3000;
  }
  ASSERT_EQ(blinks.size(), 600u);  // 10 Hz for 60 s
  int n = 0;
  double sum = 0, sum_sq = 0;
  for (const auto& [seq, rx] : blinks) {
    ASSERT_EQ(rx.size(), 4u);
    // Blinks 100 ms apart from 1 ms (after the first sync).
    EXPECT_EQ(emission_us[seq], 1000 + int64_t{100'000} * seq);
    const double t = utime_to_s(emission_us[seq]);
    const Eigen::Vector3d tag = sc.trajectories[0].path.at(t).position;
    // Distance and true clock offset at the reception.
    auto arrival = [&](const char* id) {
      const double d = (tag - sc.site.find_anchor(id)->position).norm();
      return std::pair{d, uwb_tdoa_clock_truth(section, world, id, t + d / kC).offset_s};
    };
    for (auto [i, j] : {std::pair{"A2", "A1"}, std::pair{"A4", "A3"}}) {
      const auto [di, offi] = arrival(i);
      const auto [dj, offj] = arrival(j);
      const double ticks =
          wrap_ticks(static_cast<double>(rx.at(i) - rx.at(j)) - (offi - offj) * kHz);
      const double err = ticks / kHz - (di - dj) / kC;
      ++n;
      sum += err;
      sum_sq += err * err;
    }
  }
  const double mean = sum / n, sd = std::sqrt(sum_sq / n - mean * mean);
  const double tick = 1.0 / kHz;
  const double expected_sd = std::sqrt(2 * sigma_s * sigma_s + 2 * tick * tick / 12);
  // n = 1200: 4 standard errors of the mean and of the standard deviation (1 / sqrt(2n)).
  EXPECT_NEAR(mean, 0.0, 4 * expected_sd / std::sqrt(n));
  EXPECT_NEAR(sd, expected_sd, 4 * expected_sd / std::sqrt(2.0 * n));
}

TEST(UwbTdoaModel, SyncEveryTwoSecondsAtEveryNonMasterAndTheMastersOwnRecord) {
  const Scenario sc = parse_scenario_text(
      scenario_text("    master: A3\n    drift_max_ppb: 45\n    rx_noise_sigma_ns: 0.2\n", 60),
      "my.yaml");
  std::map<std::string, std::vector<const uwb_rx_t*>> syncs;
  const std::vector<Rx> rx = run_rx(sc, 5);
  for (const Rx& r : rx)
    if (r.msg.is_sync) syncs[r.msg.anchor_id].push_back(&r.msg);
  ASSERT_EQ(syncs.size(), 4u);  // A1, A2, A4 receive; A3 reports its transmissions
  const SimWorld world{sc.site, sc.trajectories, 5};
  const YamlField& section = sc.sensor("uwb_tdoa")->section;
  for (const auto& [anchor, list] : syncs) {
    // t = 0, 2, ..., 58 s; the one at 60 s is reported 2 ms after the end.
    ASSERT_EQ(list.size(), 30u) << anchor;
    const double tof_s =
        (sc.site.find_anchor(anchor)->position - sc.site.find_anchor("A3")->position).norm() / kC;
    for (size_t k = 0; k < list.size(); ++k) {
      EXPECT_EQ(list[k]->sender_id, "A3");
      EXPECT_EQ(list[k]->seq, static_cast<int32_t>(k));
      EXPECT_EQ(list[k]->utime, kStart + 2'000 + static_cast<int64_t>(k) * 2'000'000);
      // The sync counter is the anchor's true clock at t + time of flight (within 6 sigma).
      const double t = 2.0 * static_cast<double>(k) + tof_s;
      const double expected = (t + uwb_tdoa_clock_truth(section, world, anchor, t).offset_s) * kHz;
      EXPECT_NEAR(wrap_ticks(static_cast<double>(list[k]->rx_counter) - expected), 0.0,
                  anchor == "A3" ? 1.0 : 6 * 0.2e-9 * kHz);
    }
  }
}

TEST(UwbTdoaModel, ClockDriftStaysWithinTheConfiguredPpb) {
  // Rates measured from sync intervals (true interval 2 s; timestamp noise gives a rate error
  // of sqrt(2) * 0.2 ns / 2 s = 0.14 ppb) are within drift_max_ppb and match the truth.
  const Scenario sc = parse_scenario_text(
      scenario_text("    master: A1\n    drift_max_ppb: 30\n    rx_noise_sigma_ns: 0.2\n", 20),
      "my.yaml");
  const SimWorld world{sc.site, sc.trajectories, 9};
  const YamlField& section = sc.sensor("uwb_tdoa")->section;
  std::map<std::string, std::vector<int64_t>> counters;
  for (const Rx& r : run_rx(sc, 9))
    if (r.msg.is_sync) counters[r.msg.anchor_id].push_back(r.msg.rx_counter);
  ASSERT_EQ(counters.size(), 4u);
  for (const auto& [anchor, c] : counters) {
    const double truth_ppb = uwb_tdoa_clock_truth(section, world, anchor, 0).rate_ppb;
    EXPECT_LE(std::abs(truth_ppb), 30.0);
    for (size_t k = 1; k < c.size(); ++k) {
      const double rate_ppb =
          (wrap_ticks(static_cast<double>(c[k] - c[k - 1])) / (2.0 * kHz) - 1.0) * 1e9;
      EXPECT_NEAR(rate_ppb, truth_ppb, 5 * 0.14) << anchor;
      EXPECT_LE(std::abs(rate_ppb), 30.0 + 5 * 0.14) << anchor;
    }
  }
  // Over 2000 seeds the drawn rates are uniform in +-30 ppb: all inside, mean 0 and standard
  // deviation 30 / sqrt(3) = 17.3 ppb (standard errors 0.39 and 0.19 ppb).
  double sum = 0, sum_sq = 0, max_abs = 0;
  const int seeds = 2000;
  for (int s = 0; s < seeds; ++s) {
    const SimWorld w{sc.site, sc.trajectories, static_cast<uint64_t>(s)};
    const double r = uwb_tdoa_clock_truth(section, w, "A2", 0).rate_ppb;
    sum += r;
    sum_sq += r * r;
    max_abs = std::max(max_abs, std::abs(r));
  }
  const double mean = sum / seeds, sd = std::sqrt(sum_sq / seeds - mean * mean);
  EXPECT_LE(max_abs, 30.0);
  EXPECT_GT(max_abs, 29.0);  // P(all 2000 within 29) = (29/30)^2000 ~ 1e-29
  EXPECT_NEAR(mean, 0.0, 4 * 0.39);
  EXPECT_NEAR(sd, 30.0 / std::sqrt(3.0), 4 * 0.19);
}

TEST(UwbTdoaModel, RateRandomWalkGrowsWithTheSquareRootOfTime) {
  // With drift_random_walk_ppb_per_sqrt_s = 1, the rate change after 100 s has sigma 10 ppb
  // over seeds (500 seeds: standard error of the sigma 0.32 ppb).
  const Scenario sc = parse_scenario_text(
      scenario_text("    drift_max_ppb: 0\n    drift_random_walk_ppb_per_sqrt_s: 1\n"), "my.yaml");
  const YamlField& section = sc.sensor("uwb_tdoa")->section;
  double sum_sq = 0;
  const int seeds = 500;
  for (int s = 0; s < seeds; ++s) {
    const SimWorld w{sc.site, sc.trajectories, static_cast<uint64_t>(s)};
    const double r = uwb_tdoa_clock_truth(section, w, "A3", 100.0).rate_ppb;
    sum_sq += r * r;
  }
  EXPECT_NEAR(std::sqrt(sum_sq / seeds), 10.0, 4 * 0.32);
}

TEST(UwbTdoaModel, LossRateAndSurvivorsUnchangedByLosses) {
  // 30 % loss over 60 s: 600 blinks x 4 anchors + 30 syncs x 3 receivers = 2490 receptions,
  // binomial sigma sqrt(0.3 * 0.7 / 2490) = 0.0092. The master's transmit records are never lost.
  // Every survivor is byte-identical to the lossless run: each reception draws its random values
  // whether or not it is lost.
  const std::string params = "    master: A2\n    rx_noise_sigma_ns: 0.2\n";
  const Scenario lossy =
      parse_scenario_text(scenario_text(params + "    loss_probability: 0.3\n", 60), "my.yaml");
  const Scenario lossless = parse_scenario_text(scenario_text(params, 60), "my.yaml");
  std::map<std::tuple<std::string, std::string, int32_t>, std::vector<uint8_t>> reference;
  int reference_count = 0, master_records = 0;
  for (const Rx& r : run_rx(lossless, 4)) {
    reference[{r.msg.anchor_id, r.msg.sender_id, r.msg.seq}] = r.bytes;
    if (r.msg.anchor_id != "A2" || !r.msg.is_sync) ++reference_count;
  }
  ASSERT_EQ(reference_count, 2490);
  int received = 0;
  for (const Rx& r : run_rx(lossy, 4)) {
    if (r.msg.anchor_id == "A2" && r.msg.is_sync) {
      ++master_records;
    } else {
      ++received;
    }
    auto it = reference.find({r.msg.anchor_id, r.msg.sender_id, r.msg.seq});
    ASSERT_NE(it, reference.end());
    EXPECT_EQ(it->second, r.bytes);
  }
  EXPECT_EQ(master_records, 30);
  EXPECT_NEAR(received / 2490.0, 0.7, 4 * 0.0092);
}

TEST(UwbTdoaModel, OutOfRangeAndBehindWallsNotReceived) {
  // A far anchor (150 m) hears neither blinks nor syncs with max_range_m 100.
  {
    std::string text = scenario_text("    max_range_m: 100\n", 10);
    text.replace(text.find("    - {id: U1"), 0,
                 "    - {id: A9, kind: uwb_tdoa, position: [150, 0, 2.5]}\n");
    for (const Rx& r : run_rx(parse_scenario_text(text, "my.yaml"), 1))
      EXPECT_NE(r.msg.anchor_id, "A9");
  }
  // tdoa-hall without losses: in the L-shaped room (12 x 8 m without x > 6, y > 4) a blink
  // reaches exactly the anchors whose straight path stays out of the cut-out corner (checked
  // here by sampling the path every 1 cm), and at least 4 of them.
  std::string text = builtin_scenario_text("tdoa-hall");
  text.replace(text.find("loss_probability: 0.02"), 22, "loss_probability: 0");
  Scenario sc = parse_scenario_text(text, "tdoa-hall");
  sc.duration_s = 30;  // one 28 m lap
  auto in_sight = [](const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
    for (int k = 0; k <= 2000; ++k) {
      const Eigen::Vector3d p = a + (b - a) * (k / 2000.0);
      if (p.x() > 6 && p.y() > 4) return false;
    }
    return true;
  };
  std::map<int32_t, std::set<std::string>> heard;
  std::map<int32_t, double> emission_s;
  std::map<std::string, int> syncs;
  for (const Rx& r : run_rx(sc, 2)) {
    if (r.msg.is_sync) {
      ++syncs[r.msg.anchor_id];
      continue;
    }
    heard[r.msg.seq].insert(r.msg.anchor_id);
    emission_s[r.msg.seq] = utime_to_s(r.msg.utime - kStart - 2000);
  }
  for (const auto& [seq, ids] : heard) {
    const Eigen::Vector3d tag = sc.trajectories[0].path.at(emission_s[seq]).position;
    std::set<std::string> visible;
    for (const auto& a : sc.site.anchors)
      if (in_sight(tag, a.position)) visible.insert(a.id);
    EXPECT_EQ(ids, visible) << "blink " << seq << " at " << tag.transpose();
  }
  ASSERT_EQ(heard.size(), 300u);
  int heard_by_all = 0;
  for (const auto& [seq, ids] : heard) {
    EXPECT_GE(ids.size(), 4u) << "blink " << seq;
    heard_by_all += ids.size() == 6;
  }
  // All 6 from the lower-left quarter of the room, 4 or 5 elsewhere.
  EXPECT_GT(heard_by_all, 30);
  EXPECT_LT(heard_by_all, 270);
  EXPECT_EQ(syncs.size(), 6u);  // master A4 at the inner corner reaches every anchor
  for (const auto& [id, count] : syncs) EXPECT_EQ(count, 15) << id;
}

TEST(UwbTdoaModel, SameSeedSameBytesOtherSeedOtherCounters) {
  Scenario sc = load_scenario("tdoa-hall");
  sc.duration_s = 20;
  const auto a = run_rx(sc, 7), b = run_rx(sc, 7), c = run_rx(sc, 8);
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) ASSERT_EQ(a[i].bytes, b[i].bytes) << "message " << i;
  size_t n = std::min(a.size(), c.size()), differing = 0;
  for (size_t i = 0; i < n; ++i) differing += a[i].bytes != c[i].bytes;
  EXPECT_GT(differing, n * 9 / 10);
}

TEST(UwbTdoaModel, BadParametersNameFileLineAndField) {
  EXPECT_EQ(config_error(scenario_text("    master: A9\n")),
            "my.yaml:16: sensors.uwb_tdoa.master: 'A9' is not an enabled uwb_tdoa anchor of the "
            "site");
  // U1 is a two-way-ranging anchor, not a TDoA one.
  EXPECT_EQ(config_error(scenario_text("    master: U1\n")),
            "my.yaml:16: sensors.uwb_tdoa.master: 'U1' is not an enabled uwb_tdoa anchor of the "
            "site");
  EXPECT_EQ(config_error(scenario_text("    clocks: {U1: {offset_s: 1}}\n")),
            "my.yaml:16: sensors.uwb_tdoa.clocks.U1: 'U1' is not an enabled uwb_tdoa anchor of "
            "the site");
  EXPECT_EQ(config_error(scenario_text("    clocks: {A1: {offset_s: 18}}\n")),
            "my.yaml:16: sensors.uwb_tdoa.clocks.A1.offset_s: must be in [0, 17.2]");
  EXPECT_EQ(config_error(scenario_text("    sync_period_s: 20\n")),
            "my.yaml:16: sensors.uwb_tdoa.sync_period_s: must be in [0.01, 17]");
  EXPECT_EQ(config_error(scenario_text("    rx_noise_sigma_ns: -0.1\n")),
            "my.yaml:16: sensors.uwb_tdoa.rx_noise_sigma_ns: must be in [0, 1000]");
  EXPECT_EQ(config_error(scenario_text("    room_outline: [[0, 0], [1, 0]]\n")),
            "my.yaml:16: sensors.uwb_tdoa.room_outline: expected a polygon of at least 3 points "
            "[x, y]");
  EXPECT_EQ(config_error(scenario_text("    drift_ppb: 3\n"))
                .rfind("my.yaml:16: sensors.uwb_tdoa.drift_ppb: unknown field (known: ", 0),
            0u);
  // A site without TDoA anchors.
  std::string text = scenario_text("    blink_rate_hz: 10\n");
  for (size_t at; (at = text.find("kind: uwb_tdoa")) != std::string::npos;)
    text.replace(at, 14, "kind: uwb");
  EXPECT_EQ(config_error(text),
            "my.yaml:16: sensors.uwb_tdoa: no enabled uwb_tdoa anchor in site.anchors");
}

}  // namespace
}  // namespace ips::sim
