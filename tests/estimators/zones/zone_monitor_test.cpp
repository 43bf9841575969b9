// ips-zones' core: hysteresis at a zone's border, floors, dwell, the crossing time interpolated
// between poses, and the alerts (zone events, silent tags, degraded and silent processes).
#include "estimators/zones/zone_monitor.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "core/site.hpp"

namespace ips::zones {
namespace {

constexpr int64_t kT0 = 1767225600000000;  // 2026-01-01

// A 4 x 4 m room from (0, 0), on every floor unless said; 0.3 m hysteresis (the default).
Site site_of(const std::string& extra) {
  return parse_site_text("name: z\nanchors:\n  - {id: A1, position: [0, 0, 2]}\n" + extra,
                         "site.yaml");
}

const char* const kRoom =
    "zones:\n  - {id: room, name: Room, polygon: [[0, 0], [4, 0], [4, 4], [0, 4]]}\n";

struct Recorder {
  std::vector<zone_event_t> events;
  std::vector<alert_t> alerts;
  ZoneMonitor monitor;
  explicit Recorder(ZoneMonitorOptions o = {})
      : monitor(
            o, [this](const zone_event_t& e) { events.push_back(e); },
            [this](const alert_t& a) { alerts.push_back(a); }) {}
};

pose_t pose_at(double t_s, double x, double y, double z = 1.2, const std::string& tag = "T1") {
  pose_t p{};
  p.utime = kT0 + static_cast<int64_t>(std::llround(t_s * 1e6));
  p.source = "test";
  p.tag_id = tag;
  p.position[0] = x;
  p.position[1] = y;
  p.position[2] = z;
  return p;
}

double seconds(int64_t utime) { return 1e-6 * static_cast<double>(utime - kT0); }

TEST(ZoneMonitor, AWalkThroughGivesEnterAndLeaveAtTheBoundaryCrossings) {
  Recorder r;
  r.monitor.set_site(site_of(kRoom));
  // 1 m/s along y = 2 from x = -2 to 6, poses every 0.3 s: the walls are at x = 0 and 4, crossed
  // at t = 2 and 6 s, confirmed at the first pose 0.3 m further (t = 2.4 s, 6.3 s).
  for (int i = 0; i <= 27; ++i) r.monitor.on_pose(pose_at(0.3 * i, -2 + 0.3 * i, 2));
  ASSERT_EQ(r.events.size(), 2u);
  EXPECT_EQ(r.events[0].event, zone_event_t::EVENT_ENTER);
  EXPECT_NEAR(seconds(r.events[0].utime), 2.0, 1e-6);
  EXPECT_NEAR(r.events[0].position[0], 0.0, 1e-9);
  EXPECT_NEAR(r.events[0].position[1], 2.0, 1e-9);
  EXPECT_EQ(r.events[0].zone_id, "room");
  EXPECT_EQ(r.events[0].zone_name, "Room");
  EXPECT_EQ(r.events[0].floor, zone_event_t::FLOOR_ANY);
  EXPECT_EQ(r.events[0].pose_channel, "POSE_FUSED");
  EXPECT_EQ(r.events[0].source, "ips-zones");
  EXPECT_EQ(r.events[0].seq, 0);
  EXPECT_FALSE(r.events[0].alert);
  EXPECT_EQ(r.events[1].event, zone_event_t::EVENT_LEAVE);
  EXPECT_NEAR(seconds(r.events[1].utime), 6.0, 1e-6);
  EXPECT_NEAR(r.events[1].position[0], 4.0, 1e-9);
  EXPECT_NEAR(r.events[1].dwell_s, 4.0, 1e-6);
  EXPECT_EQ(r.events[1].seq, 1);
  EXPECT_TRUE(r.alerts.empty());
}

TEST(ZoneMonitor, ATagZigZaggingOnTheBorderEntersOnce) {
  Recorder r;
  r.monitor.set_site(site_of(kRoom));
  // Along the wall x = 0, 0.2 m either side of it, 20 times; then well inside, then back on the
  // border and zig-zagging again before leaving for good.
  double t = 0;
  for (int i = 0; i < 20; ++i, t += 0.1) r.monitor.on_pose(pose_at(t, i % 2 ? 0.2 : -0.2, 2));
  EXPECT_TRUE(r.events.empty());
  // The last crossing inward was between t = 1.8 (x = -0.2) and 1.9 (x = 0.2): at 1.85 s.
  r.monitor.on_pose(pose_at(t, 1.0, 2));
  ASSERT_EQ(r.events.size(), 1u);
  EXPECT_EQ(r.events[0].event, zone_event_t::EVENT_ENTER);
  EXPECT_NEAR(seconds(r.events[0].utime), 1.85, 1e-6);
  t += 0.1;
  for (int i = 0; i < 20; ++i, t += 0.1) r.monitor.on_pose(pose_at(t, i % 2 ? -0.2 : 0.2, 2));
  EXPECT_EQ(r.events.size(), 1u);  // still in: never 0.3 m out
  const double last = t - 0.1;     // at x = -0.2, crossed out since last - 0.05
  r.monitor.on_pose(pose_at(t, -1.0, 2));
  ASSERT_EQ(r.events.size(), 2u);
  EXPECT_EQ(r.events[1].event, zone_event_t::EVENT_LEAVE);
  EXPECT_NEAR(seconds(r.events[1].utime), last - 0.05, 1e-6);
}

TEST(ZoneMonitor, TheFirstPoseInsideEntersAtOnce) {
  Recorder r;
  r.monitor.set_site(site_of(kRoom));
  r.monitor.on_pose(pose_at(1.0, 0.1, 2));  // 0.1 m inside: less than the hysteresis
  ASSERT_EQ(r.events.size(), 1u);
  EXPECT_EQ(r.events[0].event, zone_event_t::EVENT_ENTER);
  EXPECT_NEAR(seconds(r.events[0].utime), 1.0, 1e-9);
}

TEST(ZoneMonitor, AZoneOnAFloorCountsOnlyOnIt) {
  Recorder r;
  r.monitor.set_site(
      site_of("floors:\n  - {index: 0, height_m: 0}\n  - {index: 1, height_m: 3.5}\n"
              "zones:\n  - {id: up, floor: 1, polygon: [[0, 0], [4, 0], [4, 4], [0, 4]]}\n"));
  // Inside the polygon on floor 0 (pose height 1.2 m): nothing.
  r.monitor.on_pose(pose_at(0, 2, 2, 1.2));
  r.monitor.on_pose(pose_at(1, 2.5, 2, 1.2));
  EXPECT_TRUE(r.events.empty());
  // Up the stairs: on floor 1 by the pose's height, inside: ENTER at that pose.
  r.monitor.on_pose(pose_at(2, 2.5, 2, 4.7));
  ASSERT_EQ(r.events.size(), 1u);
  EXPECT_EQ(r.events[0].event, zone_event_t::EVENT_ENTER);
  EXPECT_EQ(r.events[0].floor, 1);
  EXPECT_NEAR(seconds(r.events[0].utime), 2.0, 1e-9);
  // ALTITUDE (floor_valid) wins over the pose's height: it says floor 0, the tag has left.
  altitude_t a{};
  a.utime = kT0 + 2'500'000;
  a.tag_id = "T1";
  a.height_m = 1.2;
  a.floor = 0;
  a.floor_valid = true;
  r.monitor.on_altitude(a);
  r.monitor.on_pose(pose_at(3, 2.5, 2, 4.7));
  ASSERT_EQ(r.events.size(), 2u);
  EXPECT_EQ(r.events[1].event, zone_event_t::EVENT_LEAVE);
  EXPECT_NEAR(seconds(r.events[1].utime), 3.0, 1e-9);
  EXPECT_NEAR(r.events[1].dwell_s, 1.0, 1e-9);
  // An ALTITUDE older than kAltitudeFreshS no longer counts: the pose's height does again.
  r.monitor.on_pose(pose_at(3 + kAltitudeFreshS + 0.1, 2.5, 2, 4.7));
  ASSERT_EQ(r.events.size(), 3u);
  EXPECT_EQ(r.events[2].event, zone_event_t::EVENT_ENTER);
}

TEST(ZoneMonitor, DwellOnceAtTheMomentTheTagHadBeenInsideLongEnough) {
  Recorder r;
  r.monitor.set_site(
      site_of("zones:\n  - {id: desk, polygon: [[0, 0], [4, 0], [4, 4], [0, 4]], "
              "dwell_s: 3, alert: [dwell, leave]}\n"));
  // In at t = 2 s (x = 0), stays at the middle, poses every 0.5 s, leaves at t = 10 s.
  for (int i = 0; i <= 8; ++i) r.monitor.on_pose(pose_at(0.25 * i, -2 + 0.25 * i, 2));
  for (double t = 2.5; t < 10; t += 0.5) r.monitor.on_pose(pose_at(t, 2, 2));
  r.monitor.on_pose(pose_at(10, 2, 2));
  r.monitor.on_pose(pose_at(11, -1, 2));  // crossed x = 0 at 10 + 2/3 s
  ASSERT_EQ(r.events.size(), 3u);
  EXPECT_EQ(r.events[0].event, zone_event_t::EVENT_ENTER);
  EXPECT_NEAR(seconds(r.events[0].utime), 2.0, 1e-6);
  EXPECT_EQ(r.events[1].event, zone_event_t::EVENT_DWELL);
  EXPECT_NEAR(seconds(r.events[1].utime), 5.0, 1e-6);
  EXPECT_DOUBLE_EQ(r.events[1].dwell_s, 3.0);
  EXPECT_TRUE(r.events[1].alert);
  EXPECT_EQ(r.events[2].event, zone_event_t::EVENT_LEAVE);
  EXPECT_NEAR(seconds(r.events[2].utime), 10 + 2.0 / 3, 1e-6);
  EXPECT_NEAR(r.events[2].dwell_s, 8 + 2.0 / 3, 1e-6);
  EXPECT_TRUE(r.events[2].alert);
  // The two marked events are raised as alerts of kind ZONE, never cleared.
  ASSERT_EQ(r.alerts.size(), 2u);
  EXPECT_EQ(r.alerts[0].kind, alert_t::KIND_ZONE);
  EXPECT_EQ(r.alerts[0].state, alert_t::STATE_RAISED);
  EXPECT_EQ(r.alerts[0].subject, "T1/desk");
  EXPECT_EQ(r.alerts[0].text, "T1 in desk for 3.0 s");
  EXPECT_EQ(r.alerts[0].utime, r.events[1].utime);
  EXPECT_EQ(r.alerts[1].text, "T1 left desk after 8.7 s");
  EXPECT_EQ(r.alerts[1].seq, 1);
  EXPECT_NE(r.alerts[0].id, r.alerts[1].id);
  EXPECT_TRUE(r.monitor.open_alerts().empty());

  // Out again before dwell_s: no DWELL.
  Recorder quick;
  quick.monitor.set_site(
      site_of("zones:\n  - {id: desk, polygon: [[0, 0], [4, 0], [4, 4], [0, "
              "4]], dwell_s: 3}\n"));
  for (int i = 0; i <= 8; ++i) quick.monitor.on_pose(pose_at(0.5 * i, -2 + i, 2));  // 2 s in
  ASSERT_EQ(quick.events.size(), 2u);
  EXPECT_EQ(quick.events[1].event, zone_event_t::EVENT_LEAVE);
}

TEST(ZoneMonitor, ASilentTagIsRaisedAtTheTimeItWentSilentAndClearedWhenItComesBack) {
  Recorder r;
  r.monitor.set_site(site_of("tags:\n  - {id: T1}\n  - {id: T2}\nalerts: {tag_silent_s: 4}\n"));
  r.monitor.on_pose(pose_at(0, 10, 10, 1.2, "T1"));
  r.monitor.on_pose(pose_at(1, 10, 10, 1.2, "T3"));  // not in the site: watched all the same
  for (int i = 1; i <= 10; ++i) r.monitor.on_pose(pose_at(i, 10, 10, 1.2, "T1"));
  // T2 never heard: silent 4 s after the first pose of any tag; T3 silent since t = 1 s.
  ASSERT_EQ(r.alerts.size(), 2u);
  EXPECT_EQ(r.alerts[0].kind, alert_t::KIND_TAG_SILENT);
  EXPECT_EQ(r.alerts[0].subject, "T2");
  EXPECT_NEAR(seconds(r.alerts[0].utime), 4.0, 1e-9);
  EXPECT_EQ(r.alerts[0].text, "T2: no pose on POSE_FUSED for 4.0 s (none since ips-zones started)");
  EXPECT_EQ(r.alerts[1].subject, "T3");
  EXPECT_NEAR(seconds(r.alerts[1].utime), 5.0, 1e-9);
  EXPECT_EQ(r.alerts[1].text, "T3: no pose on POSE_FUSED for 4.0 s");
  EXPECT_EQ(r.alerts[1].severity, alert_t::SEVERITY_WARNING);
  EXPECT_EQ(r.monitor.open_alerts().size(), 2u);
  // T3 back at t = 11 s: the same id, cleared.
  r.monitor.on_pose(pose_at(11, 10, 10, 1.2, "T3"));
  ASSERT_EQ(r.alerts.size(), 3u);
  EXPECT_EQ(r.alerts[2].state, alert_t::STATE_CLEARED);
  EXPECT_EQ(r.alerts[2].id, r.alerts[1].id);
  EXPECT_EQ(r.alerts[2].text, "T3: poses on POSE_FUSED again after 10.0 s");
  EXPECT_EQ(r.monitor.open_alerts().size(), 1u);
  // Live, the clock goes on without messages: T1 silent 4 s after its last pose (t = 10 s).
  r.monitor.advance_clocks(kT0 + 14'500'000, 0);
  ASSERT_EQ(r.alerts.size(), 4u);
  EXPECT_EQ(r.alerts[3].subject, "T1");
  EXPECT_NEAR(seconds(r.alerts[3].utime), 14.0, 1e-9);
}

health_t health_of(double t_s, const std::string& source, int8_t state,
                   const std::string& error = "") {
  health_t h{};
  h.utime = kT0 + static_cast<int64_t>(std::llround(t_s * 1e6));
  h.source = source;
  h.host = "lab1";
  h.pid = 42;
  h.uptime_us = 10'000'000 + static_cast<int64_t>(std::llround(t_s * 1e6));
  h.state = state;
  h.last_error = error;
  return h;
}

TEST(ZoneMonitor, ADegradedProcessIsRaisedAndClearedWithTheSameId) {
  Recorder r;
  r.monitor.set_site(site_of(""));
  r.monitor.on_health(health_of(0, "ips-fuse", health_t::STATE_OK));
  r.monitor.on_health(health_of(1, "ips-fuse", health_t::STATE_DEGRADED, "dropped 3: 3 gated"));
  r.monitor.on_health(health_of(2, "ips-fuse", health_t::STATE_DEGRADED, "dropped 3: 3 gated"));
  ASSERT_EQ(r.alerts.size(), 1u);
  EXPECT_EQ(r.alerts[0].kind, alert_t::KIND_PROCESS_DEGRADED);
  EXPECT_EQ(r.alerts[0].severity, alert_t::SEVERITY_WARNING);
  EXPECT_EQ(r.alerts[0].subject, "ips-fuse@lab1");
  EXPECT_EQ(r.alerts[0].text, "ips-fuse on lab1: degraded: dropped 3: 3 gated");
  // Worse: the degraded alert ends and an error alert (critical) starts.
  r.monitor.on_health(health_of(3, "ips-fuse", health_t::STATE_ERROR, "socket closed"));
  ASSERT_EQ(r.alerts.size(), 3u);
  EXPECT_EQ(r.alerts[1].state, alert_t::STATE_CLEARED);
  EXPECT_EQ(r.alerts[1].id, r.alerts[0].id);
  EXPECT_EQ(r.alerts[2].severity, alert_t::SEVERITY_CRITICAL);
  EXPECT_EQ(r.alerts[2].text, "ips-fuse on lab1: in error: socket closed");
  r.monitor.on_health(health_of(4, "ips-fuse", health_t::STATE_OK));
  ASSERT_EQ(r.alerts.size(), 4u);
  EXPECT_EQ(r.alerts[3].state, alert_t::STATE_CLEARED);
  EXPECT_EQ(r.alerts[3].id, r.alerts[2].id);
  EXPECT_EQ(r.alerts[3].text, "ips-fuse on lab1: OK again, no longer in error");
  EXPECT_TRUE(r.monitor.open_alerts().empty());

  // process_degraded: false in the site: not watched.
  Recorder off;
  off.monitor.set_site(site_of("alerts: {process_degraded: false}\n"));
  off.monitor.on_health(health_of(1, "ips-fuse", health_t::STATE_ERROR, "x"));
  EXPECT_TRUE(off.alerts.empty());
}

TEST(ZoneMonitor, AProcessWithoutHealthIsGoneUntilItReportsAgain) {
  ZoneMonitorOptions o;
  o.self_host = "lab1";
  o.self_pid = 7;
  Recorder r(o);
  r.monitor.set_site(site_of("alerts: {process_silent_s: 3}\n"));
  // A one-shot tool: HEALTH at start and at exit, 0.5 s apart; never "gone".
  health_t tool = health_of(0, "ips-bus-check", health_t::STATE_OK);
  tool.uptime_us = 0;
  r.monitor.on_health(tool);
  tool.utime += 500'000;
  tool.uptime_us = 500'000;
  r.monitor.on_health(tool);
  for (int i = 0; i <= 10; ++i) {
    r.monitor.on_health(health_of(i, "ips-aoa", health_t::STATE_OK));
    if (i <= 2) r.monitor.on_health(health_of(i, "ips-pdr", health_t::STATE_OK));
  }
  ASSERT_EQ(r.alerts.size(), 1u);
  EXPECT_EQ(r.alerts[0].kind, alert_t::KIND_PROCESS_GONE);
  EXPECT_EQ(r.alerts[0].severity, alert_t::SEVERITY_CRITICAL);
  EXPECT_EQ(r.alerts[0].subject, "ips-pdr@lab1");
  EXPECT_NEAR(seconds(r.alerts[0].utime), 5.0, 1e-9);
  EXPECT_EQ(r.alerts[0].text, "ips-pdr on lab1: no HEALTH for 3.0 s");
  r.monitor.on_health(health_of(11, "ips-pdr", health_t::STATE_OK));
  ASSERT_EQ(r.alerts.size(), 2u);
  EXPECT_EQ(r.alerts[1].state, alert_t::STATE_CLEARED);
  EXPECT_EQ(r.alerts[1].id, r.alerts[0].id);
  EXPECT_EQ(r.alerts[1].text, "ips-pdr on lab1: HEALTH again after 9.0 s");
  // Its own HEALTH (source, host and pid) is not watched: degraded or silent, no alert.
  health_t self = health_of(12, "ips-zones", health_t::STATE_DEGRADED, "x");
  self.pid = 7;
  r.monitor.on_health(self);
  EXPECT_EQ(r.alerts.size(), 2u);
  EXPECT_EQ(r.monitor.stats().health_in, 2 + 14 + 1);
}

TEST(ZoneMonitor, BadPosesAreCountedNotUsed) {
  Recorder r;
  r.monitor.on_pose(pose_at(0, 1, 1));  // no site yet
  r.monitor.set_site(site_of(kRoom));
  pose_t nan = pose_at(1, NAN, 2);
  r.monitor.on_pose(nan);
  r.monitor.on_pose(pose_at(2, 2, 2));
  r.monitor.on_pose(pose_at(1.5, 2, 2));  // older than the last
  EXPECT_EQ(r.monitor.drop_reasons().count(DropReason::kNoSite), 1);
  EXPECT_EQ(r.monitor.drop_reasons().count(DropReason::kInvalid), 1);
  EXPECT_EQ(r.monitor.drop_reasons().count(DropReason::kLate), 1);
  ASSERT_EQ(r.events.size(), 1u);
}

TEST(ZoneMonitor, TheLastCrossingOfASegment) {
  const std::vector<Eigen::Vector2d> square = {{0, 0}, {4, 0}, {4, 4}, {0, 4}};
  EXPECT_NEAR(last_boundary_crossing(square, {-1, 2}, {1, 2}), 0.5, 1e-12);
  // Through the whole square: the exit is the last crossing.
  EXPECT_NEAR(last_boundary_crossing(square, {-1, 2}, {5, 2}), 5.0 / 6, 1e-12);
  EXPECT_DOUBLE_EQ(last_boundary_crossing(square, {1, 1}, {2, 2}), 1.0);
}

}  // namespace
}  // namespace ips::zones
