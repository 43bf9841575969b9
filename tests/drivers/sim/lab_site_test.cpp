// config/sites/lab.yaml is the site the built-in `lab` scenario publishes on SITE: every anchor
// kind, the barometer station, the tag with its start pose and the estimators' settings. Without
// this, estimators run with --site on the file lose POSE_TDOA, POSE_AOA and ALTITUDE unnoticed.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <ips/site_t.hpp>
#include <set>
#include <string>

#include "drivers/sim/simulator.hpp"

namespace ips::sim {
namespace {

constexpr utime_t kStart = 1767225600000000;

// What ips-sim --scenario lab publishes first: its SITE message, as an estimator reads it.
Site published_lab_site() {
  Simulator sim(load_scenario("lab"), 1, kStart);
  SimEvent e;
  while (sim.next(e)) {
    if (e.kind != "SITE") continue;
    site_t m;
    m.decode(e.data.data(), 0, static_cast<int>(e.data.size()));
    return site_from_msg(m);
  }
  ADD_FAILURE() << "the lab scenario published no SITE";
  return {};
}

bool same_number(double a, double b) { return (std::isnan(a) && std::isnan(b)) || a == b; }

TEST(LabSiteFile, IsWhatTheLabScenarioPublishes) {
  const Site file = load_site_file(IPS_SOURCE_DIR "/config/sites/lab.yaml");
  const Site sim = published_lab_site();
  EXPECT_EQ(file.name, sim.name);

  ASSERT_EQ(file.anchors.size(), sim.anchors.size());
  std::set<std::string> kinds;
  for (size_t i = 0; i < file.anchors.size(); ++i) {
    const Anchor& f = file.anchors[i];
    const Anchor& s = sim.anchors[i];
    EXPECT_EQ(f.id, s.id);
    EXPECT_EQ(f.kind, s.kind) << f.id;
    EXPECT_EQ(f.position, s.position) << f.id;
    EXPECT_LT((f.orientation_rad - s.orientation_rad).norm(), 1e-12) << f.id;
    EXPECT_EQ(f.enabled, s.enabled) << f.id;
    kinds.insert(f.kind);
  }
  EXPECT_EQ(kinds, (std::set<std::string>{"uwb", "uwb_tdoa", "ble_aoa"}));

  ASSERT_EQ(file.baro_stations.size(), sim.baro_stations.size());
  for (size_t i = 0; i < file.baro_stations.size(); ++i) {
    EXPECT_EQ(file.baro_stations[i].id, sim.baro_stations[i].id);
    EXPECT_EQ(file.baro_stations[i].position, sim.baro_stations[i].position);
  }

  ASSERT_EQ(file.tags.size(), sim.tags.size());
  for (size_t i = 0; i < file.tags.size(); ++i) {
    const Tag& f = file.tags[i];
    const Tag& s = sim.tags[i];
    EXPECT_EQ(f.id, s.id);
    EXPECT_TRUE(same_number(f.height_m, s.height_m)) << f.id;
    for (int k = 0; k < 3; ++k)
      EXPECT_TRUE(same_number(f.start_position[k], s.start_position[k])) << f.id << " " << k;
    EXPECT_TRUE(same_number(f.start_heading_rad, s.start_heading_rad)) << f.id;
  }

  // The estimators' settings, key by key (YAML text, whatever the order of the keys).
  ASSERT_TRUE(file.estimators.defined());
  ASSERT_TRUE(sim.estimators.defined());
  const YAML::Node fe = file.estimators.node();
  const YAML::Node se = sim.estimators.node();
  ASSERT_EQ(fe.size(), se.size());
  for (const auto& kv : fe) {
    const std::string name = kv.first.as<std::string>();
    ASSERT_TRUE(se[name]) << "estimators." << name << " is not in the lab scenario's site";
    EXPECT_EQ(YAML::Dump(kv.second), YAML::Dump(se[name])) << "estimators." << name;
  }

  // The zones and the alert rules (ips-zones).
  ASSERT_EQ(file.layout.zones.size(), sim.layout.zones.size());
  EXPECT_FALSE(file.layout.zones.empty());
  for (size_t i = 0; i < file.layout.zones.size(); ++i) {
    const Zone& f = file.layout.zones[i];
    const Zone& s = sim.layout.zones[i];
    EXPECT_EQ(f.id, s.id);
    EXPECT_EQ(f.name, s.name) << f.id;
    EXPECT_EQ(f.floor, s.floor) << f.id;
    EXPECT_EQ(f.polygon, s.polygon) << f.id;
    EXPECT_TRUE(f.alert.enter == s.alert.enter && f.alert.leave == s.alert.leave &&
                f.alert.dwell == s.alert.dwell)
        << f.id;
    EXPECT_EQ(f.dwell_s, s.dwell_s) << f.id;
    EXPECT_EQ(f.hysteresis_m, s.hysteresis_m) << f.id;
  }
  EXPECT_EQ(file.layout.alerts.tag_silent_s, sim.layout.alerts.tag_silent_s);
  EXPECT_EQ(file.layout.alerts.process_silent_s, sim.layout.alerts.process_silent_s);
  EXPECT_EQ(file.layout.alerts.process_degraded, sim.layout.alerts.process_degraded);

  // The floor and its plan: the scenario carries config/sites/lab-plan.svg as a data URI, the
  // file reads it; the same bytes (after editing the SVG, paste `base64 -w0` of it there).
  ASSERT_EQ(file.layout.floors.size(), 1u);
  ASSERT_EQ(sim.layout.floors.size(), 1u);
  const Floor& ff = file.layout.floors[0];
  const Floor& sf = sim.layout.floors[0];
  EXPECT_EQ(ff.index, sf.index);
  EXPECT_EQ(ff.name, sf.name);
  EXPECT_EQ(ff.height_m, sf.height_m);
  ASSERT_TRUE(ff.plan && sf.plan);
  EXPECT_EQ(ff.plan->origin, sf.plan->origin);
  EXPECT_EQ(ff.plan->size_m, sf.plan->size_m);
  EXPECT_EQ(ff.plan->rotation_rad, sf.plan->rotation_rad);
  EXPECT_EQ(ff.plan->data_uri.rfind("data:image/svg+xml;base64,", 0), 0u);
  EXPECT_EQ(ff.plan->data_uri, sf.plan->data_uri)
      << "config/scenarios/lab.yaml's plan_images is not config/sites/lab-plan.svg";
}

// The lab is a showcase: its tag starts where the site says (dead reckoning starts right), and
// its barometers' offsets are those the site's altitude settings take off.
TEST(LabSiteFile, StartPoseAndBarometerOffsetsMatchTheSimulatedLab) {
  const Scenario sc = load_scenario("lab");
  const Tag* t1 = sc.site.find_tag("T1");
  ASSERT_NE(t1, nullptr);
  ASSERT_TRUE(t1->has_start());
  const TrajectoryState st = sc.trajectories[0].path.at(0.0);
  EXPECT_NEAR((st.position.head<2>() - t1->start_position.head<2>()).norm(), 0.0, 1e-9);
  EXPECT_NEAR(std::remainder(st.heading_rad - t1->start_heading_rad, 2 * M_PI), 0.0, 1e-9);

  const SensorSection* baro = sc.sensor("baro");
  ASSERT_NE(baro, nullptr);
  const YAML::Node sim_offsets = baro->section.node()["offsets_pa"];
  const YAML::Node site_offsets = sc.site.estimator_params("altitude").node()["offsets_pa"];
  ASSERT_TRUE(sim_offsets && site_offsets);
  ASSERT_EQ(sim_offsets.size(), site_offsets.size());
  for (const auto& kv : sim_offsets) {
    const std::string id = kv.first.as<std::string>();
    ASSERT_TRUE(site_offsets[id]) << id;
    EXPECT_DOUBLE_EQ(kv.second.as<double>(), site_offsets[id].as<double>()) << id;
  }
}

// --tags N: the copies wait at the start and walk the same path, so they start where T1 does.
TEST(LabSiteFile, ReplicatedWalkersKeepTheStartPose) {
  Scenario sc = load_scenario("lab");
  replicate_walkers(sc, 3);
  const Tag* t3 = sc.site.find_tag("T1-3");
  ASSERT_NE(t3, nullptr);
  ASSERT_TRUE(t3->has_start());
  EXPECT_EQ(t3->start_position.head<2>(), sc.site.find_tag("T1")->start_position.head<2>());
  EXPECT_DOUBLE_EQ(t3->start_heading_rad, sc.site.find_tag("T1")->start_heading_rad);
}

}  // namespace
}  // namespace ips::sim
