#pragma once
// What ips-view shows: the site's anchors, per (channel, tag) the latest position estimate with
// its horizontal covariance and a bounded trail, a channel table in the spirit of lcm-spy
// (messages, Hz, age, bytes per second) and the HEALTH of every process. Pure: fed decoded
// messages with the channel they came on and the host time they arrived, returns values (the
// live page's JSON here, the floor map in svg_render.hpp); main.cpp owns the clock and sockets.
//
// Everything here came off an unauthenticated bus: the number of tracks, channels, processes and
// anchors is bounded, ids longer than ViewOptions::max_id_bytes are dropped, free text (sources,
// last_error) is truncated, and all of it is counted in ViewStats instead of thrown. Strings are
// escaped where they leave (json_string() here, xml_text() in svg_render.hpp), never on entry.
#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <ips/alert_t.hpp>
#include <ips/altitude_t.hpp>
#include <ips/health_t.hpp>
#include <ips/pose_t.hpp>
#include <ips/zone_event_t.hpp>
#include <ips/site_t.hpp>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <tuple>
#include <utility>
#include <vector>

#include "core/channel_colours.hpp"
#include "core/health_state.hpp"
#include "core/site.hpp"
#include "core/time.hpp"

namespace ips::view {

struct ViewOptions {
  // Trails are by time: the positions of the last trail_s seconds (of arrival time: the log's in
  // a log), at most trail_length of them (a 50 Hz track keeps 40 s); 0: no trail.
  double trail_s = 20.0;
  size_t trail_length = 2000;
  size_t max_tracks = 2048;    // (channel, tag) pairs
  size_t max_channels = 128;   // rows of the channel table
  size_t max_processes = 128;  // (source, host, pid) keys of HEALTH
  size_t max_anchors = 1000;   // a SITE with more is refused (counted as a bad site)
  size_t max_zone_events = 200;  // the latest zone events kept
  size_t max_alerts = 500;       // alerts kept (raised ones first; the oldest ended one gives way)
  size_t max_tags = 1024;        // tags with an ALTITUDE kept
  // Tag ids, channel names and HEALTH sources and hosts longer than this are dropped (they are
  // keys); a pose's source is cut to this length, last_error and site errors to max_error_bytes.
  size_t max_id_bytes = 128;
  size_t max_error_bytes = 512;
  double rate_window_s = 5.0;  // the channel table's Hz and bytes/s are over this window
  size_t rate_samples = 512;   // arrivals remembered per channel (at a higher rate the window
                               // is effectively shorter; the rate stays right)
  // When a table is full, a new key takes the place of the entry silent longest if it has been
  // silent this long (host time); otherwise the new key is dropped and counted.
  double expire_s = 60.0;
};

struct ViewStats {
  int64_t sites_in = 0;
  int64_t bad_sites = 0;  // site_yaml that does not parse, or too many anchors
  int64_t poses_in = 0;
  int64_t non_finite_positions = 0;  // x or y NaN/inf: not stored
  int64_t health_in = 0;
  int64_t altitudes_in = 0;
  int64_t zone_events_in = 0;
  int64_t alerts_in = 0;
  int64_t bytes_messages_in = 0;  // on_bytes calls
  int64_t dropped_long_ids = 0;   // a key (tag id, channel, source, host) over max_id_bytes
  int64_t dropped_too_many_tracks = 0;
  int64_t dropped_too_many_channels = 0;
  int64_t dropped_too_many_processes = 0;
  int64_t dropped_too_many_alerts = 0;  // the table full of raised alerts
  int64_t dropped_too_many_tags = 0;
  int64_t expired = 0;  // entries that gave way to a new key (see ViewOptions::expire_s)
};

// The horizontal positions of a track with their times, in a ring allocated once: the newest
// `capacity`, of which points() gives those of the last `window_s` seconds.
class Trail {
 public:
  Trail() = default;
  Trail(size_t capacity, double window_s) : ring_(capacity), window_s_(window_s) {}
  void push(utime_t t, const Eigen::Vector2d& p);
  size_t size() const { return size_; }
  size_t capacity() const { return ring_.size(); }
  // Oldest first, those within window_s of the newest.
  std::vector<Eigen::Vector2d> points() const;

 private:
  struct Point {
    utime_t t;
    Eigen::Vector2d p;
  };
  std::vector<Point> ring_;
  double window_s_ = 0;
  size_t next_ = 0;
  size_t size_ = 0;
};

// The latest estimate of one tag on one channel.
struct Track {
  std::string channel;
  std::string tag;
  std::string source;                                  // the latest pose's, cut to max_id_bytes
  utime_t utime = 0;                                   // the pose's own time
  utime_t host_utime = 0;                              // when it arrived
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // m, site frame; z may be NaN
  Eigen::Matrix2d cov_xy = Eigen::Matrix2d::Constant(std::numeric_limits<double>::quiet_NaN());
  double heading_rad = std::numeric_limits<double>::quiet_NaN();
  int32_t status = 0;  // pose_t::STATUS_* bits
  int64_t count = 0;   // poses stored
  int64_t non_finite = 0;
  Trail trail;
};

// A tag's height and floor from ALTITUDE.
struct TagHeight {
  double height_m = std::numeric_limits<double>::quiet_NaN();
  int floor = kNoFloor;  // kNoFloor when the estimator gave none
  bool relative = false;
  utime_t host_utime = 0;
};

// One alert (alert_t), kept from RAISED to CLEARED and a while after.
struct AlertRow {
  alert_t last;               // the latest message of this (source, id)
  utime_t raised_utime = 0;   // the RAISED message's time (its own utime)
  utime_t cleared_utime = 0;  // 0 while raised
  bool acked = false;
  utime_t host_utime = 0;
};

// One row of the channel table at a given host time.
struct ChannelRow {
  std::string channel;
  int64_t count = 0;
  int64_t bytes = 0;
  // Over the arrivals within rate_window_s before `now`: k >= 2 of them give (k - 1) / their
  // span (the mean spacing, so 10 messages 0.1 s apart are 10 Hz); one gives 1 / window; none, 0.
  double rate_hz = 0;
  double bytes_per_s = 0;  // rate_hz times the mean size over the same arrivals
  double age_s = 0;        // since the last message
};

// One process's latest HEALTH.
struct Process {
  health_t health;  // last_error cut to max_error_bytes
  utime_t host_utime = 0;
};

// later - earlier in seconds, for any two times (bus and log times are not trusted to be close:
// their difference in microseconds may not fit in 64 bits).
inline double seconds_between(utime_t later, utime_t earlier) {
  utime_t d = 0;
  if (!__builtin_sub_overflow(later, earlier, &d)) return utime_to_s(d);  // exact to the us
  return utime_to_s(later) - utime_to_s(earlier);
}

using ips::health_state_name;  // core/health_state.hpp
// pose_t::STATUS_* bits as names ("ok", "initialising", "coasting", "2d", "reinitialised").
std::vector<std::string> status_names(int32_t status);

// The n-sigma ellipse of a horizontal covariance: semi-axes n * sqrt(eigenvalue) (the closed-form
// eigen-decomposition of the symmetric 2x2 matrix), the major axis at angle_rad from +x
// counter-clockwise, in (-pi/2, pi/2]. For n = 2 it holds 86.5 % of a 2-D Gaussian.
struct Ellipse {
  double semi_major_m = 0;
  double semi_minor_m = 0;
  double angle_rad = 0;
};
// None when the covariance is not finite or not positive definite.
std::optional<Ellipse> covariance_ellipse(const Eigen::Matrix2d& cov, double n_sigma);

// A JSON string literal (quotes included) safe to embed in HTML: quote and backslash escaped,
// control characters and DEL as \u00XX, < > & as \u003c \u003e \u0026 (so "</script>" cannot
// close a script element), U+2028/U+2029 escaped, and bytes that are not valid UTF-8 as \ufffd.
std::string json_string(std::string_view s);
// A JSON number (up to 10 significant digits), null when not finite.
std::string json_number(double v);

using ips::channel_colours;  // core/channel_colours.hpp: the same colours in every program

class ViewModel {
 public:
  using TrackKey = std::pair<std::string, std::string>;              // channel, tag
  using ProcessKey = std::tuple<std::string, std::string, int32_t>;  // source, host, pid

  explicit ViewModel(ViewOptions options = {});

  // A site whose site_yaml does not parse (or with more than max_anchors anchors) is counted and
  // its error kept; the previous site stays.
  void on_site(const site_t& msg, utime_t host_utime);
  // Any pose channel: TRUTH, POSE_*, INS_MODULE, or any other name.
  void on_pose(const std::string& channel, const pose_t& msg, utime_t host_utime);
  void on_health(const health_t& msg, utime_t host_utime);
  void on_altitude(const altitude_t& msg, utime_t host_utime);
  void on_zone_event(const zone_event_t& msg, utime_t host_utime);
  void on_alert(const alert_t& msg, utime_t host_utime);
  // Marks an alert as seen by someone at the page; false when there is no such alert.
  bool ack_alert(const std::string& source, int64_t id);
  // Every message of every channel, for the channel table.
  void on_bytes(const std::string& channel, size_t bytes, utime_t host_utime);

  // The live page's snapshot: site, anchors (in the site's order), tracks, channels, processes
  // (each sorted by its key) and stats; ages in seconds before `now` (host time). Without
  // trails, each track's "trail" is left out (the live stream: the page keeps its own trails).
  // `brief`: each track without what the page does not read (utime, cov_xy, heading_rad, status,
  // non_finite): the live stream's snapshot, about a third smaller.
  std::string json(utime_t now, bool with_trails = true, bool brief = false) const;
  // The site as the page draws it: name, anchors, floors with their plans (data URIs), zones.
  // Changes only with site_version().
  std::string site_json() const;
  int64_t site_version() const { return site_version_; }
  const SiteLayout& layout() const { return layout_; }
  // The floor a track is on: its tag's ALTITUDE floor when it has one, else the site's floor at
  // the track's height; kNoFloor without floors in the site or a height.
  int track_floor(const Track& t) const;

  const ViewOptions& options() const { return options_; }
  const ViewStats& stats() const { return stats_; }
  bool has_site() const { return has_site_; }
  const std::string& site_name() const { return site_name_; }
  const std::vector<Anchor>& anchors() const { return anchors_; }
  const std::string& last_site_error() const { return last_site_error_; }
  const std::map<TrackKey, Track>& tracks() const { return tracks_; }
  const std::map<ProcessKey, Process>& processes() const { return processes_; }
  std::vector<ChannelRow> channel_table(utime_t now) const;
  // The distinct channels that carry tracks, sorted.
  std::vector<std::string> pose_channels() const;

 private:
  struct Arrival {
    utime_t host_utime;
    size_t bytes;
  };
  struct ChannelMeter {
    std::vector<Arrival> ring;
    size_t next = 0;
    size_t size = 0;
    int64_t count = 0;
    int64_t bytes = 0;
    utime_t last_host_utime = 0;
  };

  ChannelRow row(const std::string& channel, const ChannelMeter& m, utime_t now) const;

  ViewOptions options_;
  ViewStats stats_;
  bool has_site_ = false;
  std::string site_name_;
  std::string site_source_;
  utime_t site_host_utime_ = 0;
  std::vector<Anchor> anchors_;
  SiteLayout layout_;
  std::string site_yaml_;  // the text the layout and site_version_ are of
  int64_t site_version_ = 0;
  std::string last_site_error_;
  std::map<std::string, TagHeight> heights_;
  std::vector<zone_event_t> zone_events_;  // ring of the latest, oldest at zone_next_
  size_t zone_next_ = 0;
  std::map<std::pair<std::string, int64_t>, AlertRow> alerts_;
  std::map<TrackKey, Track> tracks_;
  std::map<std::string, ChannelMeter> channels_;
  std::map<ProcessKey, Process> processes_;
};

}  // namespace ips::view
