#pragma once
// BLE angle-of-arrival tag positioning (source 000): ble_aoa_t events of several anchors ->
// pose_t per tag.
//   1. Each event: the anchor must be a ble_aoa anchor of the site; the angles are corrected
//      with the anchor's calibration polynomials (aoa_calibration.hpp).
//   2. Events are grouped into epochs, one per advertisement (epoch_grouper.hpp); when an anchor
//      reports an advertisement more than once (multipath copies, channel-hopping
//      near-duplicates: 000 section 7.2.1) one angle is kept (DuplicatePolicy).
//   3. Either a per-epoch solver (bearing lines, Gauss-Newton/"Newton-Raphson", steepest
//      descent, Levenberg-Marquardt; aoa_solvers.hpp) gives the pose of each epoch, warm-started
//      from the tag's previous one as in the source, or an EKF on the angles
//      (models/aoa_bearing.hpp): constant velocity (default) or the source's random walk, with
//      scalar updates per angle and Mahalanobis gating, started from a per-epoch fix.
// 2D (the tag's height from the site: azimuths only, as in the source) or 3D (no height in the
// site, or force_3d: azimuth and elevation).
// Pure: takes messages, emits pose_t through a callback, never reads a clock.
#include <deque>
#include <functional>
#include <ips/ble_aoa_t.hpp>
#include <ips/pose_t.hpp>
#include <map>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "core/consistency.hpp"
#include "core/cv_filter.hpp"
#include "core/drop_reasons.hpp"
#include "core/time_guard.hpp"
#include "core/pose_tally.hpp"
#include "core/site.hpp"
#include "estimators/aoa/aoa_calibration.hpp"
#include "estimators/aoa/aoa_solvers.hpp"
#include "estimators/aoa/epoch_grouper.hpp"

namespace ips::aoa {

// Which of several angles of one anchor in one epoch is kept.
enum class DuplicatePolicy {
  kStrongest,  // highest RSSI: the direct path is normally the strongest (default)
  kFirst,      // the earliest: reflections travel further and are reported later
  kWeakest,    // lowest RSSI: source 000's parseAoAData, literally (7.2.2 step 3)
  kNearest,    // closest to the track's prediction (EKF; strongest until there is a track)
};

enum class AoaMethod { kEkf, kPerEpoch };
enum class AoaMotion { kConstantVelocity, kRandomWalk };

struct AoaParams {
  AoaMethod method = AoaMethod::kEkf;
  // The per-epoch solver: the published one with method per_epoch, the EKF's start otherwise.
  AoaSolver solver = AoaSolver::kLevenbergMarquardt;
  AoaSolveOptions solve;  // iteration limits and LM schedule (solver, dims and start are set here)
  bool force_3d = false;
  bool warm_start = true;  // per-epoch solves start from the tag's previous pose (source)
  double azimuth_sigma_deg = 5.0;    // source R = 5^2 deg^2 per anchor
  double elevation_sigma_deg = 5.0;
  // Angles far off the antenna normal are worse (000 section 4: > 10 deg error beyond +-60
  // deg): sigma * (1 + edge_sigma_gain (gamma / 90 deg)^2), gamma the angle off the normal.
  double edge_sigma_gain = 1.0;
  double epoch_window_s = 0.06;
  DuplicatePolicy duplicate = DuplicatePolicy::kStrongest;
  AoaMotion motion = AoaMotion::kConstantVelocity;
  double accel_psd = 0.5;             // constant velocity: (m/s^2)^2/Hz
  double random_walk_psd = 1.44;      // random walk: Q = q dt I, source q = 1.2^2 m^2/s
  double initial_sigma_m = 3.0;       // source P0 = diag(3^2, 3^2) m^2
  double initial_velocity_sigma_mps = 1.0;
  double gate_sigma = 3.0;            // reject |innovation| > gate_sigma sqrt(S)
  int min_anchors = 2;                // a per-epoch fix needs this many anchors
  // A per-epoch fix whose horizontal standard deviation (from its covariance) exceeds this is
  // not used: two nearly parallel lines (opposite anchors, the rest lost) cross anywhere.
  double max_fix_sigma_m = 1.5;
  // Start again from a fix when, within disagree_window_s, at least reinit_after_rejections
  // angles were gated and they outnumber the accepted ones (most anchors disagree for a while;
  // one anchor that still agrees does not hold a wrong track).
  int reinit_after_rejections = 10;
  double disagree_window_s = 2.0;
  // Accepted angles from fewer than two anchors for this long: the position is not observable
  // (one bearing is a line): the pose is published without STATUS_OK; for max_coast_s: restart.
  double single_anchor_s = 1.0;
  // The site's box: the anchors' bounding box grown by max_outside_m horizontally, and from
  // max_below_m under the lowest anchor to max_outside_m over the highest (tags are under the
  // anchors). A fix outside is not used, a track that leaves it starts again, and no pose
  // outside is published.
  double max_outside_m = 1.0;
  double max_below_m = 3.0;
  // The EKF's angle innovations per anchor are checked against their assumed variance
  // (core/consistency.hpp, kinds ANGLE and ELEVATION, source the anchor id) and, with
  // learn_noise, each anchor's angle variance is learned from them (never below the configured
  // one).
  bool learn_noise = true;
  // The EKF's state constraint: a tag is never closer to an anchor than this (its far field: an
  // XPLR-AOA array of about 15 cm aperture measures plane waves only beyond 2 D^2 / lambda =
  // 0.36 m; the board itself is on a wall or the ceiling). An update that ends closer is moved
  // out to this distance along the anchor's own measured bearing (the one angle that still
  // knows the direction there; the others only say "near this anchor").
  double min_anchor_distance_m = 0.3;
  double max_coast_s = 3.0;           // no accepted angle for this long: start again
  double publish_period_s = 0.0;      // 0: a pose per epoch
  double reorder_tolerance_s = 0.1;   // epochs this far behind the track are still used
  int max_tags = 1000;
};

// Reads `estimators.aoa` of the site (calibration excluded); throws ConfigError.
AoaParams parse_aoa_params(const YamlField& section);
std::optional<DuplicatePolicy> parse_duplicate_policy(const std::string& name);

struct AoaStats {
  int64_t events_in = 0;
  int64_t angles_used = 0;              // accepted by the EKF, or used in a per-epoch solve
  int64_t rejected_gate = 0;
  int64_t duplicates = 0;               // extra angles of an anchor in an epoch, not kept
  int64_t dropped_unknown_anchor = 0;   // not a ble_aoa anchor of the site, or disabled
  int64_t dropped_no_anchors = 0;       // the site has no enabled ble_aoa anchor at all
  int64_t dropped_invalid = 0;          // NaN or |angle| > 90 deg, implausible utime, no tag id
  int64_t dropped_outside_calibration = 0;  // beyond a correction's interval with beyond: reject
  int64_t dropped_no_site = 0;
  int64_t dropped_late = 0;             // an epoch older than the track by reorder_tolerance_s
  int64_t dropped_too_many_tags = 0;
  int64_t epochs = 0;
  int64_t epochs_too_few_anchors = 0;   // per-epoch: no fix (fewer than min_anchors)
  int64_t solve_failures = 0;           // per-epoch solver found no position
  int64_t fixes_poor_geometry = 0;      // a fix beyond max_fix_sigma_m, not used
  int64_t fixes_outside = 0;            // a fix outside the site's box, not used
  int64_t reinit_outside = 0;           // EKF restarts: the track left the site's box
  int64_t reinit_disagree = 0;          // EKF restarts: most angles gated for a while
  int64_t reinit_unobservable = 0;      // EKF restarts: one anchor's angles only for max_coast_s
  int64_t poses_not_ok = 0;             // published without STATUS_OK (one anchor only)
  int64_t moved_off_anchor = 0;         // EKF states moved out to min_anchor_distance_m
  int64_t initialisations = 0;
  int64_t poses_out = 0;

  // The events that gave no estimate, by reason (epochs and fixes where the text says so).
  DropReasons drop_reasons() const {
    DropReasons d;
    d.add(DropReason::kNoSite, dropped_no_site);
    d.add(DropReason::kNoAnchorsOfKind, dropped_no_anchors);
    d.add(DropReason::kUnknownAnchor, dropped_unknown_anchor);
    d.add(DropReason::kInvalid, dropped_invalid);
    d.add(DropReason::kOutsideCalibration, dropped_outside_calibration);
    d.add(DropReason::kLate, dropped_late);
    d.add(DropReason::kTooManyTags, dropped_too_many_tags);
    d.add(DropReason::kDuplicate, duplicates);
    d.add(DropReason::kGated, rejected_gate);
    d.add(DropReason::kTooFewAnchors, epochs_too_few_anchors);
    d.add(DropReason::kNoFix, solve_failures + fixes_poor_geometry + fixes_outside);
    return d;
  }
};

// One advertisement's angles after calibration and the duplicate policy, for a tightly coupled
// filter (ips-fuse runs this class on BLE_AOA for them): `picked[i].anchor` indexes the site's
// anchors, `angles[i]` holds its angles and their standard deviations.
struct AoaEpochAngles {
  const std::string* tag_id = nullptr;
  utime_t utime = 0;
  const std::vector<AoaEvent>* picked = nullptr;
  const std::vector<BearingObservation>* angles = nullptr;
};

class AoaEstimator {
 public:
  using PoseSink = std::function<void(const pose_t&)>;
  using EpochSink = std::function<void(const AoaEpochAngles&)>;
  explicit AoaEstimator(PoseSink sink, std::string source_name = "aoa");

  // Every epoch's angles go to `sink` before the tracker sees them; with `track` false there is
  // no tracker (no poses), only calibration, grouping and the choice among duplicates.
  void set_epoch_sink(EpochSink sink, bool track);

  // Anchors, tag heights, parameters and calibration; resets all tracks. Throws ConfigError on
  // bad parameters (the estimator keeps its previous site then).
  void set_site(const Site& site);
  bool has_site() const { return site_.has_value(); }
  void on_event(const ble_aoa_t& msg);
  // Closes the epochs whose window ended by `now` (live: the bus went quiet).
  void flush(utime_t now);
  // End of input: closes every open epoch.
  void finish();

  const AoaStats& stats() const { return stats_; }
  DropReasons drop_reasons() const {
    DropReasons d = stats_.drop_reasons();
    d.add(DropReason::kTimeJump, guard_.dropped());
    return d;
  }
  // Time plausibility of the events, per anchor (core/time_guard.hpp).
  const TimeGuardStats& time_stats() const { return guard_.stats(); }
  // The newest event time taken (0 before the first): a live process closes epochs from it.
  utime_t newest_event_utime() const { return guard_.newest(); }
  const AoaParams& params() const { return params_; }
  // The EKF's angle innovations per anchor against their assumed noise (every angle, gated ones
  // too); per-epoch solves have no prediction and feed nothing.
  const ConsistencyMonitor& consistency() const { return consistency_; }
  // Overrides the site's method/solver (ips-aoa --method, comparisons); kept across set_site.
  void override_method(AoaMethod method, std::optional<AoaSolver> solver = std::nullopt);

 private:
  // A random-walk position filter (the source's EKF: F = I, Q = q dt I).
  template <int D>
  struct RwFilter {
    static constexpr int N = D;
    Vec<N> x = Vec<N>::Zero();
    Mat<N> P = Mat<N>::Identity();
    void predict(double dt, double q) {
      if (dt > 0) P.diagonal().array() += q * dt;
    }
  };
  struct Track {
    bool planar = true;
    double height_m = 0;
    bool initialised = false;
    CvFilter<2> cv2;
    CvFilter<3> cv3;
    RwFilter<2> rw2;
    RwFilter<3> rw3;
    utime_t filter_utime = 0;
    utime_t last_accept_utime = 0;
    struct Verdict {
      utime_t utime;
      size_t anchor;
      bool accepted;
    };
    std::deque<Verdict> verdicts;   // the EKF's angles within disagree_window_s
    utime_t observable_utime = 0;   // the last time two anchors' angles were accepted
    std::optional<Eigen::Vector3d> last_fix;  // warm start of the per-epoch solver
    utime_t last_fix_utime = 0;
    PoseTally tally;
  };

  void on_epoch(Epoch& epoch);
  // One angle per anchor, chosen by the duplicate policy.
  void pick_angles(const Epoch& epoch, const Track* track, std::vector<AoaEvent>& out);
  // Into `obs` (a reused buffer).
  void observations(const std::vector<AoaEvent>& events, std::vector<BearingObservation>& obs) const;
  double sigma_rad(double base_deg, double az_deg, double el_deg) const;
  // The per-epoch fix of these angles (warm-started from `start` when given); nullopt, counted,
  // when it fails or its geometry is too poor.
  std::optional<AoaSolution> fix(const Track& t, const std::vector<AoaEvent>& events,
                                 const std::optional<Eigen::Vector3d>& start);
  void per_epoch(Track& t, const std::string& tag_id, utime_t utime,
                 const std::vector<AoaEvent>& events);
  bool initialise(Track& t, utime_t utime, const std::vector<AoaEvent>& events);
  template <class F>
  void filter_epoch(Track& t, F& f, const std::string& tag_id, utime_t utime,
                    const std::vector<AoaEvent>& events);
  template <class F>
  Eigen::Vector3d track_position(const Track& t, const F& f) const;
  template <class F>
  void publish_filter(Track& t, const F& f, const std::string& tag_id, utime_t utime);
  void emit(Track& t, pose_t& p, utime_t utime);
  // The state constraint min_anchor_distance_m on the filter's position.
  template <class F>
  void keep_off_anchors(Track& t, F& f, const std::vector<AoaEvent>& events);
  // Inside the site's box (see max_outside_m).
  bool inside_site(const Eigen::Vector3d& p) const;

  PoseSink sink_;
  EpochSink epoch_sink_;
  bool track_ = true;
  std::string source_;
  std::optional<Site> site_;
  AoaParams params_;
  std::optional<AoaMethod> method_override_;
  std::optional<AoaSolver> solver_override_;
  std::vector<AnchorFrame> frames_;                // per site anchor
  std::vector<bool> usable_;                       // enabled ble_aoa anchors
  std::vector<AnchorCalibration> calibration_;     // per site anchor
  double default_height_m_ = 0;                    // 2D without a tag height: the anchors' mean
  Eigen::Vector3d box_min_ = Eigen::Vector3d::Zero(), box_max_ = Eigen::Vector3d::Zero();  // anchors
  std::map<std::string, Track> tracks_;
  EpochGrouper grouper_;
  int64_t order_ = 0;
  std::vector<AoaEvent> picked_;  // scratch
  std::vector<BearingObservation> angles_;  // scratch: picked_'s, or a fix's
  std::unordered_map<std::string, size_t> anchor_index_;  // site anchor id -> index
  AoaStats stats_;
  TimeGuard guard_;  // per anchor
  ConsistencyMonitor consistency_;
  std::string azimuth_setting_, elevation_setting_;  // as the monitor names them
};

}  // namespace ips::aoa
