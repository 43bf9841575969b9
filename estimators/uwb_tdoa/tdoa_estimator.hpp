#pragma once
// UWB TDoA tag tracker (ips-uwb-tdoa): anchor clocks synchronised to the sync master
// (clock_sync.hpp), each tag blink's receptions grouped by (tag, seq) and converted to master
// time, range differences to a reference anchor, and a constant-velocity EKF per tag (2D with
// the tag height from the site, or 3D) with Mahalanobis-gated TDoA updates (models/tdoa.hpp).
// Tracks start, and restart after long coasting or repeated rejections, from a per-epoch
// Levenberg-Marquardt TDoA fix (tdoa_least_squares.hpp). Pairwise TDoA as Loco-style systems
// deliver it (uwb_tdoa_t, clocks synchronised upstream) goes to a PairTracker
// (pair_tracker.hpp) that shares the pose sink, the drop counts and the consistency monitor.
// Pure: takes uwb_rx_t, emits pose_t and clock_t through callbacks, never reads a clock; runs on
// message time only, so a log replayed gives the same output.
#include <array>
#include <deque>
#include <functional>
#include <ips/clock_t.hpp>
#include <ips/pose_t.hpp>
#include <ips/uwb_rx_t.hpp>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/cv_filter.hpp"
#include "core/drop_reasons.hpp"
#include "core/consistency.hpp"
#include "core/time_guard.hpp"
#include "core/pose_tally.hpp"
#include "core/site.hpp"
#include "estimators/uwb_tdoa/clock_sync.hpp"
#include "estimators/uwb_tdoa/pair_tracker.hpp"

namespace ips::uwb_tdoa {

// One blink's receptions in master time, for a tightly coupled filter (ips-fuse runs this class
// on UWB_RX for its clock synchronisation and blink grouping): anchor k received it at
// `range_m[k]` metres of light after the earliest arrival, with variance `var_m2[k]` (reception
// plus that anchor's clock estimate). At most kMaxEpochArrivals anchors, the earliest first.
inline constexpr int kMaxEpochArrivals = 16;
struct TdoaEpoch {
  const std::string* tag_id = nullptr;
  utime_t utime = 0;
  int count = 0;
  std::array<Eigen::Vector3d, kMaxEpochArrivals> anchor;
  std::array<double, kMaxEpochArrivals> range_m{};
  std::array<double, kMaxEpochArrivals> var_m2{};
};

enum class ReferenceChoice {
  kNearest,  // the anchor nearest the tag's estimate (before one: the earliest arrival)
  kMaster,   // the sync master, whose clock needs no estimate
  kAnchor,   // a named anchor
};

struct TdoaParams {
  ClockSyncParams clock;
  bool force_3d = false;  // estimate height even when the site gives one
  ReferenceChoice reference = ReferenceChoice::kNearest;
  std::string reference_anchor;  // for kAnchor
  bool sequential = false;       // scalar updates per difference instead of one vector update
  // Timestamp noise of one blink reception: 004's R = 3e-20 s^2 (sqrt = 0.17 ns, 5 cm).
  double rx_sigma_ns = 0.17;
  // Learn each anchor's sync noise from its innovations (core/consistency.hpp), never below
  // sync_sigma_ns.
  bool learn_noise = true;
  double accel_psd = 0.5;        // process noise, (m/s^2)^2/Hz
  double gate_sigma = 4.0;       // reject a difference with |innovation| > gate_sigma * sqrt(S)
  double epoch_window_s = 0.05;  // reports of one blink arrive within this of the first
  double init_velocity_sigma_mps = 1.0;
  double init_max_residual_m = 0.3;   // a fix with a larger RMS residual is not trusted
  int reinit_after_rejections = 5;    // consecutive blinks with most differences gated
  double max_coast_s = 3.0;           // no accepted difference for this long: re-initialise
  double publish_period_s = 0.1;      // at most one pose per tag per period
  double reorder_tolerance_s = 0.05;  // reports this far behind the tag's newest are still used
  int max_tags = 1000;                // tracks kept at most (ids off the bus)
  // Pairwise TDoA (UWB_TDOA, pair_tracker.hpp): pair_sigma_m, pair_gate_sigma, pair_lost_level,
  // pair_lost_share, pair_window_s; the rest shared with the raw path above.
  PairParams pairs;
};

// Reads `estimators.uwb_tdoa` of the site; throws ConfigError on a bad value (including a
// `master` or `reference` that is not an enabled uwb_tdoa anchor of the site).
TdoaParams parse_tdoa_params(const YamlField& section, const Site& site);

struct TdoaStats {
  int64_t rx_in = 0;
  int64_t blinks_in = 0;               // tag receptions (is_sync false)
  int64_t dropped_invalid = 0;         // bad counter or counter_hz, empty ids, implausible utime
  int64_t dropped_unknown_anchor = 0;  // not an enabled uwb_tdoa anchor of the site
  int64_t dropped_no_anchors = 0;      // the site has no enabled uwb_tdoa anchor at all
  int64_t dropped_no_site = 0;
  int64_t dropped_late = 0;  // behind the tag's newest report, or a new anchor's of a closed blink
  int64_t dropped_duplicate = 0;       // a second report of one blink from one anchor
  int64_t time_resets = 0;             // a tag's time went back by more than max_coast_s
  int64_t dropped_too_many_tags = 0;   // a new tag id while max_tags tracks are active
  int64_t rx_no_clock = 0;             // blink at an anchor whose clock is not tracking
  int64_t epochs = 0;                  // blinks processed
  int64_t epochs_too_few = 0;          // fewer than 2 anchors with a clock
  int64_t epochs_initialising = 0;     // blinks that could not start the tag's track yet
  int64_t tdoa_used = 0;               // range differences applied
  int64_t rejected_gate = 0;           // differences gated (Mahalanobis)
  int64_t rejected_geometry = 0;       // |difference| beyond the anchors' separation
  int64_t initialisations = 0;
  int64_t poses_out = 0;
};

class TdoaEstimator {
 public:
  using PoseSink = std::function<void(const pose_t&)>;
  using ClockSink = std::function<void(const clock_t&)>;
  using EpochSink = std::function<void(const TdoaEpoch&)>;
  TdoaEstimator(PoseSink pose_sink, ClockSink clock_sink, std::string source_name = "uwb_tdoa");

  // Every blink with receptions at 2 or more synchronised anchors goes to `sink` before the
  // tracker sees it; with `track` false there is no tracker (no poses), only clocks and epochs.
  void set_epoch_sink(EpochSink sink, bool track);

  // Takes the anchors, tag heights and parameters; resets every clock and track. Throws
  // ConfigError on bad parameters (the previous site stays).
  void set_site(const Site& site);
  bool has_site() const { return site_.has_value(); }
  void on_rx(const uwb_rx_t& msg);
  // One pairwise TDoA (UWB_TDOA): tracked apart from the raw receptions' tracks (a tag is
  // expected on one of the two), published through the same pose sink.
  void on_pair(const uwb_tdoa_t& msg) { pairs_.on_pair(msg); }
  const PairStats& pair_stats() const { return pairs_.stats(); }
  // Processes the blinks still waiting for more reports (at the end of a log).
  void flush();

  const TdoaStats& stats() const { return stats_; }
  const ClockSyncStats& clock_stats() const { return clocks_.stats(); }
  // The receptions (blinks and syncs) that gave no estimate, by reason; gated and initialising
  // count range differences and blinks.
  DropReasons drop_reasons() const;
  // Time plausibility of the inputs, per anchor (core/time_guard.hpp).
  const TimeGuardStats& time_stats() const { return guard_.stats(); }
  const TdoaParams& params() const { return params_; }
  const ClockSync& clocks() const { return clocks_; }
  // Each anchor's range-difference innovations against the assumed reception noise
  // (core/consistency.hpp).
  const ConsistencyMonitor& consistency() const { return consistency_; }
  const std::string& master_id() const { return clocks_.master_id(); }

 private:
  struct Reception {
    int anchor;
    int64_t counter;
  };
  struct Blink {
    int32_t seq = 0;
    utime_t utime = 0;
    std::vector<Reception> rx;  // capacity kept: no allocation per blink once warm
  };
  struct Track {
    bool planar = true;
    double height_m = 0;
    bool initialised = false;
    CvFilter<2> f2;
    CvFilter<3> f3;
    utime_t filter_utime = 0;
    utime_t newest_utime = 0;
    utime_t last_accept_utime = 0;
    int consecutive_rejections = 0;
    PoseTally tally;  // since the last pose published
    bool open = false;  // a blink is gathering reports
    Blink blink;
    bool has_closed = false;
    int32_t closed_seq = 0;  // the last blink processed, to drop its stragglers
    utime_t closed_utime = 0;
    // The anchors (index < 64) that reported it: a copy of their reports is no straggler.
    uint64_t closed_anchors = 0;
  };
  // One anchor's reception converted to master time, in metres of light travel.
  struct Arrival {
    int anchor;
    double ticks;   // master counter, [0, 2^40)
    double var_m2;  // reception noise plus clock, m^2
  };

  Track* track_for(const uwb_rx_t& m);
  void close_blink(const std::string& tag_id, Track& t);
  void close_expired(utime_t now);
  void process(const std::string& tag_id, Track& t, const Blink& b);
  bool try_initialise(Track& t, const Blink& b, const std::vector<Arrival>& arr);
  template <int D>
  void update(Track& t, CvFilter<D>& f, const Blink& b, std::vector<Arrival>& arr);
  template <int D>
  void publish(Track& t, const CvFilter<D>& f, const std::string& tag_id, utime_t now);
  Eigen::Vector3d track_position(const Track& t) const;

  PoseSink pose_sink_;
  EpochSink epoch_sink_;
  bool track_ = true;
  std::string source_;
  ClockSync clocks_;
  std::optional<Site> site_;
  TdoaParams params_;
  double counter_hz_ = 0;  // of the first valid report; every report must match it
  int reference_anchor_ = -1;
  std::map<std::string, Track> tracks_;
  std::deque<std::pair<utime_t, std::string>> open_order_;  // open blinks, oldest first
  std::vector<Arrival> arrivals_;                           // scratch, reused
  TdoaStats stats_;
  TimeGuard guard_;  // per sender (core/time_guard.hpp)
  ConsistencyMonitor consistency_;
  PairTracker pairs_;
  std::string rx_setting_;  // "rx_sigma_ns 0.17"
};

}  // namespace ips::uwb_tdoa
