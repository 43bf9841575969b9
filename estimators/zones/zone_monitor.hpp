#pragma once
// ips-zones' core: which zone of the site each tag is in (ZONE_EVENT) and the alerts of the site's
// rules (ALERT). Fed poses, altitudes, HEALTH and the site with their utimes; no clock, no LCM:
// the same messages in give the same events out (ips-replay hosts it).
//
// Zones (docs/site-file.md#zones). Per tag and zone, the tag is in once it is inside the polygon
// by at least the zone's hysteresis_m (or at its first pose inside), and out once it is outside
// by at least hysteresis_m, so a tag walking along the border does not flicker. The event's
// utime is the time the track crossed the polygon's boundary itself, interpolated linearly
// between the two poses around the last crossing before the confirmation, not the time of the
// pose that confirmed it (that pose is later by the time it took to go hysteresis_m further).
// A zone with a floor counts only while the tag is on that floor: the floor of its newest
// ALTITUDE when floor_valid (at most kAltitudeFreshS old), else floor_of_height(pose z); a
// change of floor enters or leaves at the pose that shows it.
//
// Alerts (docs/site-file.md#alerts). Two clocks, each the newest utime seen of its kind, so that
// a replay gives the same alerts: the tags' clock (poses, altitudes) times tag silence; the
// processes' clock (HEALTH, stamped by each process's host) times process silence. Live, the
// shell also advances both with the wall clock between messages (advance_clocks), so that
// silence is noticed when nothing arrives; in a replay nothing advances them but the log.
#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <ips/alert_t.hpp>
#include <ips/altitude_t.hpp>
#include <ips/health_t.hpp>
#include <ips/pose_t.hpp>
#include <ips/zone_event_t.hpp>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/drop_reasons.hpp"
#include "core/site.hpp"

namespace ips::zones {

// A process is watched for silence once it has run this long (HEALTH's uptime_us): a one-shot
// tool (ips-bus-check --wait-for) says HEALTH at start and exit, and is not "gone" when it ends.
inline constexpr double kWatchedUptimeS = 2.0;

// An ALTITUDE older than this (against the pose) no longer gives the tag's floor.
inline constexpr double kAltitudeFreshS = 5.0;

struct ZoneMonitorOptions {
  std::string source = "ips-zones";         // the source of what it publishes
  std::string pose_channel = "POSE_FUSED";  // named in events and alert texts
  // Its own HEALTH, not watched: source, host and pid (pid < 0: no process of its own, replay).
  std::string self_host;
  int32_t self_pid = -1;
};

struct ZoneMonitorStats {
  int64_t poses_in = 0;
  int64_t altitudes_in = 0;
  int64_t health_in = 0;
  int64_t events_out = 0;
  int64_t alerts_out = 0;
};

class ZoneMonitor {
 public:
  using EventSink = std::function<void(const zone_event_t&)>;
  using AlertSink = std::function<void(const alert_t&)>;
  ZoneMonitor(ZoneMonitorOptions opts, EventSink on_event, AlertSink on_alert);

  // A new site: its zones and rules apply from the next message. The state of a zone whose id
  // is still there is kept; a zone removed is forgotten without a LEAVE.
  void set_site(const Site& site);
  void on_pose(const pose_t& pose);
  void on_altitude(const altitude_t& altitude);
  void on_health(const health_t& health);
  // Live only: moves the clocks forward (never back) to these utimes; 0 leaves one as it is.
  void advance_clocks(int64_t tags_utime, int64_t processes_utime);

  // The newest utime seen of poses/altitudes, and of HEALTH (0: none yet).
  int64_t tags_clock() const { return tags_clock_; }
  int64_t processes_clock() const { return processes_clock_; }
  const DropReasons& drop_reasons() const { return drops_; }
  const ZoneMonitorStats& stats() const { return stats_; }
  // "3 tags, 2 zones; 12 events (4 ENTER, ...), 3 alerts raised, 1 open"
  std::string run_notes() const;
  // The alerts raised and not cleared, one line each.
  std::vector<std::string> open_alerts() const;

 private:
  struct ZoneTrack {
    bool known = false;       // a pose was evaluated for this zone
    bool raw_inside = false;  // inside the polygon (and on its floor) at the last pose
    bool inside = false;      // confirmed
    bool pending = false;     // crossed to the other side of `inside`, not yet confirmed
    int64_t cross_utime = 0;
    Eigen::Vector3d cross_position = Eigen::Vector3d::Zero();
    int64_t enter_utime = 0;
    bool dwell_sent = false;
  };
  struct TagState {
    bool heard = false;
    int64_t last_utime = 0;  // of its last pose; the clock's start for a tag never heard
    Eigen::Vector3d last_position = Eigen::Vector3d::Zero();
    int last_floor = kNoFloor;
    bool last_floor_known = false;
    std::map<std::string, ZoneTrack> zones;  // by zone id
    int64_t silent_alert = 0;                // the id of its open silence alert, 0 none
    int64_t altitude_utime = 0;
    int altitude_floor = kNoFloor;
    bool altitude_floor_valid = false;
  };
  struct ProcessState {
    int64_t last_utime = 0;
    int8_t state = health_t::STATE_OK;
    int64_t degraded_alert = 0;
    int8_t degraded_state = health_t::STATE_OK;
    int64_t gone_alert = 0;
    bool watched = false;  // ran kWatchedUptimeS at least
  };

  void update_zone(const Zone& zone, TagState& tag, ZoneTrack& track, const pose_t& pose,
                   const Eigen::Vector3d& p, bool floor_known, int floor);
  void emit_event(const Zone& zone, const std::string& tag_id, int8_t kind, int64_t utime,
                  const Eigen::Vector3d& position, double dwell_s);
  void publish_alert(int64_t id, int8_t kind, int8_t severity, int8_t state, int64_t utime,
                     const std::string& subject, const std::string& text);
  int64_t raise(int8_t kind, int8_t severity, int64_t utime, const std::string& subject,
                const std::string& text);
  void clear(int64_t id, int8_t kind, int8_t severity, int64_t utime, const std::string& subject,
             const std::string& text);
  void advance_tags_clock(int64_t utime);
  void advance_processes_clock(int64_t utime);
  void check_tags();
  void check_processes();

  ZoneMonitorOptions opts_;
  EventSink on_event_;
  AlertSink on_alert_;
  std::optional<Site> site_;
  std::map<std::string, TagState> tags_;
  std::map<std::string, ProcessState> processes_;  // by "source@host"
  std::map<int64_t, std::string> open_;            // alert id -> its text, while raised
  int64_t tags_clock_ = 0;
  int64_t processes_clock_ = 0;
  int64_t event_seq_ = 0;
  int64_t alert_seq_ = 0;
  int64_t next_alert_id_ = 1;
  int64_t events_by_kind_[4] = {0, 0, 0, 0};
  int64_t alerts_raised_ = 0;
  DropReasons drops_;
  ZoneMonitorStats stats_;
};

// Where the segment p0 -> p1 last crosses the polygon's boundary, as a fraction of the segment in
// [0, 1]; 1 when it does not cross it (numerically).
double last_boundary_crossing(const std::vector<Eigen::Vector2d>& polygon,
                              const Eigen::Vector2d& p0, const Eigen::Vector2d& p1);

}  // namespace ips::zones
