#pragma once
// Hybrid per-tag fusion (ips-fuse): one best estimate per tag from every sensor, sources
// ../shared/reference/001_hybrid_uwb_ins.md (UWB + foot INS) and 003_baro.md (barometric height).
// One EKF per tag (fuse_filter.hpp: position, velocity, the dead-reckoning heading bias) takes:
//  - UWB two-way ranges, tightly coupled (models/uwb_range.hpp of ips-uwb-twr, with its NLOS
//    gating and down-weighting);
//  - relative displacements as the motion model: a foot-INS module's on-board positions
//    (INS_MODULE), ips-ins's (POSE_INS) or ips-pdr's steps (STEP), differenced and rotated by the
//    estimated heading bias; without them, constant velocity;
//  - UWB TDoA blinks (UWB_RX), tightly coupled (models/tdoa.hpp): ips-uwb-tdoa's clock
//    synchronisation and blink grouping run inside, and each blink's differences update the
//    filter; a tag with blinks no longer takes POSE_TDOA (the same information, filtered);
//  - BLE angles of arrival (BLE_AOA), tightly coupled (ips-aoa's models/aoa_bearing.hpp):
//    ips-aoa's calibration, epoch grouping and duplicate choice run inside, and each angle
//    updates the filter; a tag with angles no longer takes POSE_AOA;
//  - barometric heights (ALTITUDE, models/height.hpp);
//  - other estimators' poses, loosely coupled (models/position.hpp; POSE_TDOA, POSE_AOA).
// A track starts from the site's start pose, a multilateration of ranges, a dead-reckoning
// position, another estimator's pose, or, for a tag with only blinks or only angles, the fix of
// the hosted ips-uwb-tdoa / ips-aoa tracker: ips-fuse needs no other estimator running.
// Every update is gated. Messages are fused in time order as they arrive; a late one (up to
// max_delay_s behind the tag's newest) rolls the track back to the snapshot before it and the
// later ones are fused again, so a displacement that covers ranges already fused still moves the
// state between them. With fewer anchors, or none, the track coasts on the displacements (or
// constant velocity) and its covariance grows; gated ranges are accepted again as it does.
// Pure: takes messages, emits pose_t through a callback, never reads a clock.
#include <algorithm>
#include <cstdint>
#include <deque>
#include <functional>
#include <ips/altitude_t.hpp>
#include <ips/ble_aoa_t.hpp>
#include <ips/imu_t.hpp>
#include <ips/pose_t.hpp>
#include <ips/step_t.hpp>
#include <ips/uwb_range_t.hpp>
#include <ips/uwb_rx_t.hpp>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "core/consistency.hpp"
#include "core/drop_reasons.hpp"
#include "core/pose_tally.hpp"
#include "core/repeat_filter.hpp"
#include "core/site.hpp"
#include "core/time_guard.hpp"
#include "estimators/aoa/aoa_estimator.hpp"
#include "estimators/uwb_tdoa/tdoa_estimator.hpp"
#include "estimators/uwb_twr/twr_estimator.hpp"
#include "fusion/fuse_filter.hpp"
#include "fusion/fuse_ring.hpp"
#include "fusion/gyro_heading.hpp"
#include "fusion/models/tdoa.hpp"
#include "fusion/models/tdoa_pair.hpp"

namespace ips::fusion {

enum class DisplacementSource { kAuto, kInsModule, kPoseIns, kStep, kNone };

struct FuseParams {
  bool force_3d = false;          // estimate height even when the site gives the tag's
  // Learn each anchor's range noise from its innovations (core/consistency.hpp), never below
  // range_sigma_m.
  bool learn_noise = true;
  double range_sigma_m = 0.10;
  double gate_sigma = 4.0;
  double tdoa_gate_sigma = 4.0;
  double angle_gate_sigma = 3.0;
  double nlos_gate_sigma = 2.5;
  double nlos_downweight_sigma = 1.5;
  // Ranges flagged likely NLOS by rx - first-path power, and the range bias: as ips-uwb-twr's
  // settings of the same names (estimators.uwb_twr's unless estimators.fuse says).
  double nlos_power_los_db = 6.0;
  double nlos_power_db = 10.0;
  double nlos_power_var_scale = 10.0;
  uwb_twr::NlosPower nlos_power() const {
    return {nlos_power_los_db, nlos_power_db, nlos_power_var_scale};
  }
  double range_bias_m = 0.0;
  double range_bias_per_m = 0.0;
  double accel_psd = 0.5;         // constant-velocity process noise, (m/s^2)^2/Hz
  DisplacementSource displacement = DisplacementSource::kAuto;  // auto: the first one heard
  bool gyro_turns = true;  // IMU gyros turn the velocity between displacements
  double displacement_sigma_per_m = 0.05;  // noise of a displacement, per metre moved
  double displacement_sigma_min_m = 0.01;  // ... and at least this, per displacement
  // The noise of a displacement moved_m long, per axis.
  double displacement_sigma(double moved_m) const {
    return std::max(displacement_sigma_min_m, displacement_sigma_per_m * moved_m);
  }
  double heading_bias_sigma_deg = 30.0;    // initial: the source's frame vs the site's
  double heading_bias_walk_deg_per_sqrt_s = 2.0;
  double start_sigma_m = 0.3;     // a start from the site's start pose or a dead-reckoning position
  double height_gate_sigma = 5.0;
  double pose_gate_sigma = 5.0;
  // Other estimators' poses are filtered, so their errors are correlated from one to the next:
  // their covariance is multiplied by this before they are fused.
  double pose_cov_scale = 3.0;
  double epoch_window_s = 0.6;    // ranges this close form a multilateration start
  double max_delay_s = 1.0;       // late messages up to this far behind are fused in order
  // Nothing of a tag for longer than this (the process was stopped, the machine swapped, the
  // tag out of reach): its track starts afresh from the next fix instead of coasting across.
  double max_gap_s = 3.0;
  int reinit_after_rejections = 12;
  double publish_period_s = 0.1;
  int max_tags = 1000;
};

// Reads `estimators.fuse` of the site; throws ConfigError naming file, line and field.
FuseParams parse_fuse_params(const YamlField& section);

struct FuseStats {
  int64_t messages_in = 0;
  int64_t ranges_used = 0;
  int64_t ranges_rejected = 0;
  int64_t ranges_nlos_power = 0;  // used ranges flagged likely NLOS by rx - fp power
  int64_t tdoa_epochs_used = 0;
  int64_t tdoa_epochs_rejected = 0;
  int64_t tdoa_differences_used = 0;
  int64_t angles_used = 0;
  int64_t angles_rejected = 0;
  int64_t poses_superseded = 0;  // POSE_TDOA / POSE_AOA of a tag whose blinks / angles are fused
  int64_t displacements_used = 0;
  int64_t imu_used = 0;
  int64_t heights_used = 0;
  int64_t heights_rejected = 0;
  int64_t poses_used = 0;
  int64_t poses_rejected = 0;
  int64_t dropped_invalid = 0;
  int64_t dropped_relative_height = 0;  // ALTITUDE relative to a lone barometer's start
  int64_t dropped_unknown_anchor = 0;
  int64_t anchor_pair_ranges = 0;    // UWB_RANGE between two anchors (a survey's), not a tag's
  int64_t dropped_late = 0;          // more than max_delay_s behind the tag's newest
  int64_t dropped_range_repeated = 0;  // a copy of a range already taken (core/repeat_filter.hpp)
  int64_t dropped_imu_repeated = 0;  // an IMU sample at the time of the previous one (a duplicate)
  // An IMU sample before the previous one: within max_delay_s of it, reordered on the way (a
  // LAN does that now and then; the next sample's interval covers it, routine); further back,
  // late.
  int64_t dropped_imu_reordered = 0;
  int64_t dropped_imu_late = 0;
  // The same for a dead-reckoning source's poses and steps (INS_MODULE, POSE_INS, STEP): one at
  // the time of the previous one is a copy (a LAN repeats datagrams; it was counted invalid and
  // kept ips-fuse degraded in the soak), one before it within max_delay_s reordered (the next
  // one's displacement covers it), further back late.
  int64_t dropped_dr_repeated = 0;
  int64_t dropped_dr_reordered = 0;
  int64_t dropped_dr_late = 0;
  int64_t dropped_no_site = 0;
  int64_t dropped_too_many_tags = 0;
  // Displacements of a tag's other dead-reckoning sources (one is used per tag: the first heard,
  // or estimators.fuse.displacement): left unused on purpose, so not a drop and not in
  // drop_reasons(); said once per tag and source (set_note_sink) and in run_notes().
  int64_t ignored_other_source = 0;
  int64_t waiting_start = 0;         // measurements of a tag whose track has not started yet
  int64_t rollbacks = 0;             // late messages fused in order
  int64_t initialisations = 0;
  int64_t hosted_starts = 0;  // of those, from the hosted TDoA/AoA trackers (blinks or angles only)
  int64_t restarts = 0;
  int64_t prior_refuted = 0;  // starts from a prior that the first absolute measurements refuted
  int64_t gap_restarts = 0;  // tracks started afresh after more than max_gap_s without input
  // Running tracks restarted at a fix of their ranges, which agreed among themselves on a place
  // the track was not while it gated them (check_against_ranges).
  int64_t lost_restarts = 0;
  // Poses published while a fix of the ranges far from the track waited for the next ones to
  // confirm it: their covariance widened to hold the fix (maybe_publish).
  int64_t poses_doubted = 0;
  // Dead-reckoning positions that jumped further than the track's motion explains, taken for
  // the source restarting from a new origin: not used as a displacement, re-anchored there.
  int64_t source_restarts = 0;
  int64_t poses_out = 0;
};

class FuseEstimator {
 public:
  using PoseSink = std::function<void(const pose_t&)>;
  using NoteSink = std::function<void(const std::string&)>;
  explicit FuseEstimator(PoseSink sink, std::string source_name = "fuse");
  // Information about the run that is no fault, once each: "T1: using INS_MODULE for
  // displacements, ignoring STEP" when a tag's second dead-reckoning source is first heard.
  void set_note_sink(NoteSink sink) { note_sink_ = std::move(sink); }

  void set_site(const Site& site);
  bool has_site() const { return site_.has_value(); }
  void on_range(const uwb_range_t& m);
  void on_rx(const uwb_rx_t& m);  // UWB_RX: TDoA blinks and anchor syncs
  // UWB_TDOA: one pairwise difference (models/tdoa_pair.hpp), tightly coupled; the hosted pair
  // tracker's first pose starts a tag that has nothing else.
  void on_pair(const uwb_tdoa_t& m);
  void on_aoa(const ble_aoa_t& m);  // BLE_AOA
  // Live: closes the angle epochs whose window ended by `now` (the bus went quiet).
  void flush_angles(utime_t now) { aoa_.flush(now); }
  // End of input: fuses the blinks still waiting for receptions and the open angle epochs.
  void flush() {
    tdoa_.flush();
    aoa_.finish();
  }
  void on_ins_module(const pose_t& m);  // INS_MODULE
  void on_pose_ins(const pose_t& m);    // POSE_INS
  void on_step(const step_t& m);        // STEP
  void on_altitude(const altitude_t& m);
  // IMU: the gyro of the tag (device_id) turns the constant-velocity prediction between
  // displacements (gyro_heading.hpp); nothing else of it is used.
  void on_imu(const imu_t& m);
  // Another estimator's pose (POSE_TDOA, POSE_AOA, ...), `kind` naming it in the sources.
  void on_pose(const pose_t& m, const std::string& kind);

  const FuseStats& stats() const { return stats_; }
  // The run in words, for ips-replay's summary: each tag's unused dead-reckoning sources
  // ("T1: using INS_MODULE for displacements, ignored 60 STEP") and the tracks restarted
  // because their estimates were off ("1 track(s) that had lost their tag restarted, the last:
  // T1: ..."); "" when there were none.
  std::string run_notes() const;
  // The last restart after a gap, in words ("T1: 9.6 s without input, ..."); "" before one.
  const std::string& last_gap() const { return last_gap_; }
  // The last track restarted at its ranges' fix (lost_restarts), as "T1: track 5.2 m from ...".
  const std::string& last_lost() const { return last_lost_; }
  // The last dead-reckoning source taken for restarted (source_restarts), as "T1: INS_MODULE
  // moved 4.6 m in 1.0 s, the track 1.0 m: ...".
  const std::string& last_source_restart() const { return last_source_restart_; }
  // Time plausibility of the inputs, per tag (core/time_guard.hpp).
  const TimeGuardStats& time_stats() const { return guard_.stats(); }
  // The newest time of the angles taken (0 before the first): ips-fuse's epoch flush runs from it.
  utime_t newest_angle_utime() const { return aoa_.newest_event_utime(); }
  // The UWB_RX side: ips-uwb-tdoa's blink grouping and clock synchronisation counters.
  const uwb_tdoa::TdoaStats& tdoa_stats() const { return tdoa_.stats(); }
  // The BLE_AOA side: ips-aoa's calibration and grouping counters.
  const aoa::AoaStats& aoa_stats() const { return aoa_.stats(); }
  // The inputs that were not fused, by reason (HEALTH, ips-replay's summary): the fusion's own,
  // and the UWB_RX / BLE_AOA receptions its blink and angle grouping could not use (gated
  // and initialising count measurements of a tag, not messages).
  DropReasons drop_reasons() const;
  const FuseParams& params() const { return params_; }
  // Its inputs' innovations against their assumed noise: ranges per anchor, angles per anchor,
  // heights, and other estimators' poses per kind (core/consistency.hpp).
  const ConsistencyMonitor& consistency() const { return consistency_; }
  // The tag's current state, for tests.
  std::optional<FuseFilter> filter(const std::string& tag_id) const;

 private:
  enum Source : uint32_t {
    kSrcRange = 1,
    kSrcInsModule = 2,
    kSrcPoseIns = 4,
    kSrcStep = 8,
    kSrcAltitude = 16,
    kSrcPose = 32,
    kSrcTdoa = 64,
    kSrcAngles = 128,
  };
  static constexpr int kMaxAngles = 8;  // anchors per advertisement
  // Far fixes of the ranges count together toward a lost track's restart within this
  // (check_against_ranges), and the poses after one hold it in their covariance for this long
  // (maybe_publish).
  static constexpr utime_t kFarFixSpan = 1'000'000;
  struct Angles {
    int count = 0;
    std::array<int, kMaxAngles> anchor{};  // site anchor index
    std::array<aoa::BearingObservation, kMaxAngles> angle;  // frame pointers not kept
  };
  struct Measurement {
    // kFrame: the tag's dead-reckoning source restarted in a new frame (source_restarted): from
    // `t` on, the heading bias is unknown again.
    enum class Kind { kRange, kHeight, kPosition, kDisplacement, kTdoa, kAngles, kFrame } kind =
        Kind::kRange;
    utime_t t = 0;
    utime_t t0 = 0;  // displacement: the start of its interval
    int anchor = -1;
    double value = 0;  // range, or height
    double sigma = 0;  // height sigma
    Eigen::Vector3d vec = Eigen::Vector3d::Zero();  // position, or displacement
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    bool horizontal_only = false;
    double nlos_p = 0;  // range: the likelihood of NLOS by rx - first-path power (NlosPower)
    // A blink's arrivals, or angles: out of line and shared by the copies (never changed once
    // made), so that a range's slot in the history (every tag holds max_delay_s of them in a
    // ring) is not as large as a group of arrivals or angles (224 bytes instead of 568).
    std::variant<std::monostate, std::shared_ptr<const TdoaArrivals>, std::shared_ptr<const Angles>>
        group;
    uint32_t source = 0;
    std::string pose_kind;
  };
  struct Snapshot {
    utime_t t = 0;
    utime_t velocity_t = 0;  // the time the velocity's direction is of (a displacement's middle)
    FuseFilter filter;
    utime_t last_absolute = 0;
    int rejections = 0;
    int accepted_in_row = 0;  // absolute measurements taken since the last gated one
    // Started from a prior (the site's start pose, a dead-reckoning position) and no absolute
    // measurement taken since: what the first ones say decides whether the prior holds.
    bool prior_only = false;
    bool prior_refuted = false;  // ... and the first ones refuted it (count_absolute)
    // The last absolute measurement of the horizontal position taken (ranges, blinks, angles,
    // poses; not heights): a new dead-reckoning frame is measured against the track's path only
    // where one is recent.
    utime_t last_horizontal = 0;
  };
  struct Track {
    std::string tag_id;  // the tag's (its links' noise is learned per tag: core/consistency.hpp)
    bool initialised = false;
    bool ever_started = false;   // a gap's restart takes no site start pose
    bool absolute_seen = false;  // ... nor, after a fix in the site's frame, a dead-reckoning one
    Snapshot state;
    Snapshot base;                    // the state before the history's first message
    Ring<Measurement> history;  // fused, in time order, the last max_delay_s
    Ring<Snapshot> snapshots;   // the state after each of them
    DisplacementSource displacement = DisplacementSource::kNone;
    bool have_last_dr = false;        // the last dead-reckoning position or step time
    utime_t last_dr_t = 0;
    uint32_t dr_bit = 0;              // the dead-reckoning source's bit, once one moved the track
    Eigen::Vector3d last_dr_position = Eigen::Vector3d::Zero();
    // The last ranges: a multilateration start is waited for from them, and a running track
    // checked against them.
    std::deque<Measurement> recent_ranges;
    RecentRepeats range_repeats;          // the last ranges' keys, to know a copy
    std::vector<ConsistencyMonitor::LinkId> noise_links;  // per site anchor, made on first use
    utime_t waiting_since = 0;            // the first range of the wait (0: not waiting)
    int gated_since_check = 0;            // ranges gated since the last check_against_ranges
    utime_t last_lost_check = 0;
    int lost_checks = 0;                  // far fixes since one agreed, within kFarFixSpan
    utime_t last_far_fix = 0;             // the last of them
    Eigen::Vector2d far_fix_offset = Eigen::Vector2d::Zero();  // its position minus the track's
    utime_t last_checked_fix = 0;         // the last fix of the ranges with a spare range
    bool prior_unchecked = false;         // started from a prior no such fix has checked yet
    utime_t started_at = 0;
    // The radios' per-pair range offsets, learned as ips-uwb-twr does (uwb_twr/models/
    // range_bias.hpp) from the last epoch's ranges (value: less the configured bias only).
    uwb_twr::PairOffsets offsets;
    bool offsets_set = false;
    struct RangeSample {  // what the offsets are learned from, of a range Measurement
      utime_t t = 0;
      int anchor = -1;
      double value = 0;
    };
    std::deque<RangeSample> epoch_ranges;
    utime_t last_offsets_t = 0;
    utime_t newest = 0;
    bool tight_tdoa = false;  // blinks fused: POSE_TDOA is not
    bool tight_aoa = false;   // angles fused: POSE_AOA is not
    GyroHeading gyro;
    PoseTally tally;
    uint32_t sources = 0;  // contributed since the last pose
    std::vector<std::string> pose_kinds;
  };

  // The tag's track for a message of time `t`, or nullptr when the message is not to be used now
  // (counted; or held by the time guard, which hands it over again through `again` when its
  // stamp is confirmed). A restart after a gap happens here. Defined in fuse_inputs.hpp.
  template <class Again>
  Track* track_for(const std::string& tag_id, utime_t t, Again&& again);
  // For the hosted estimators' epochs, whose stamps their own guards checked: never held; a stale
  // one is dropped; when the hosted guard went back in time (its reanchors_back moved on from
  // `seen`), so does the tag's track.
  Track* track_for_checked(const std::string& tag_id, utime_t t, int64_t hosted_reanchors_back,
                           int64_t& seen_reanchors_back);
  // Time went back for the tag: its track starts afresh (flagged REINITIALISED when it does).
  void restart_track(const std::string& tag_id);
  Track* find_or_add_track(const std::string& tag_id, utime_t t);
  // The link (this tag, a site anchor) whose range noise is learned (core/consistency.hpp).
  ConsistencyMonitor::LinkId noise_link(Track& t, size_t anchor_index);
  // A dead-reckoning pose or step at or before the tag's previous one: counted as a copy,
  // reordered or late (stats_.dropped_dr_*).
  void count_dr_out_of_turn(const Track& t, utime_t utime);
  bool planar_for(const std::string& tag_id) const;
  double tag_height(const std::string& tag_id) const;
  void add(const std::string& tag_id, Track& t, Measurement m);
  // The pairs' range offsets: set up from the site on the tag's first range, then learned from
  // each epoch of ranges as ips-uwb-twr does (r: a range less the configured bias only).
  void learn_offsets(Track& t, const Measurement& r);
  // `prior`: p is a prior (the site's start pose, a dead-reckoning position), not a fix.
  void start(const std::string& tag_id, Track& t, utime_t time, const Eigen::Vector3d& p,
             double sigma_m, bool prior = false);
  void try_start_from_ranges(const std::string& tag_id, Track& t);
  struct RangeFix {
    utime_t t = 0;
    Eigen::Vector3d position = Eigen::Vector3d::Zero();
    double sigma_m = 0;
    bool checked = false;  // a spare range checked the fix's residual
  };
  // A multilateration of the last epoch_window_s of the track's ranges, with a start's rules
  // (a spare range while first waiting and on a running track; the residual checked).
  std::optional<RangeFix> fix_from_ranges(const std::string& tag_id, Track& t);
  // A running track that gates ranges which agree on a place far from it is restarted there.
  void check_against_ranges(const std::string& tag_id, Track& t);
  // Moves the snapshot's filter to time `to`, through the displacements of the history.
  void predict(const Track& t, Snapshot& s, utime_t to) const;
  // Moves the snapshot to the measurement's time and fuses it (fuse_history.cpp) with its model,
  // one file each: `live` the first time (counted, consistency checked), not when fused again
  // after a late message.
  void apply(Track& t, Snapshot& s, const Measurement& m, bool live);
  void apply_range(Track& t, Snapshot& s, const Measurement& m, bool live);     // fuse_ranges.cpp
  void apply_tdoa(Track& t, Snapshot& s, const Measurement& m, bool live);      // fuse_tdoa.cpp
  void apply_angles(Track& t, Snapshot& s, const Measurement& m, bool live);    // fuse_angles.cpp
  void apply_height(Track& t, Snapshot& s, const Measurement& m, bool live);    // fuse_heights.cpp
  void apply_position(Track& t, Snapshot& s, const Measurement& m, bool live);  // fuse_poses.cpp
  // A displacement moved the state in predict() (fuse_displacements.cpp): counted here.
  void apply_displacement(Track& t, const Measurement& m, bool live);
  void new_frame(FuseFilter& f) const;  // a restarted dead-reckoning source's heading bias
  // A new frame's rotation measured from its held-back displacements (fuse_displacements.cpp):
  // kMeasured; kPriorStands where the track's path cannot say; kAgain where the path is no
  // rotation of the displacements' (the track was corrected meanwhile: measured afresh).
  // kAgain: the track was corrected during the window; kConfirm: a rotation far off the prior,
  // to be confirmed by the next window.
  enum class FrameCheck { kMeasured, kPriorStands, kAgain, kConfirm };
  FrameCheck measure_frame(FuseFilter& f) const;
  // An absolute measurement accepted or gated: after reinit_after_rejections gated in a row
  // the track is widened.
  // (`widen`: false where check_against_ranges judges the track instead.)
  void count_absolute(Snapshot& s, utime_t t, bool accepted, bool live, bool widen = true);
  void maybe_publish(const std::string& tag_id, Track& t);
  void on_dead_reckoning(const pose_t& m, DisplacementSource src, uint32_t bit);
  // Whether the tag's displacements come from `src`; the others are counted in
  // ignored_other_source and noted once per tag and source.
  bool accept_displacement(const std::string& tag_id, Track& t, DisplacementSource src);
  // A displacement d the track's motion cannot explain: its source restarted (counted, said).
  bool source_restarted(const std::string& tag_id, const Track& t, const Measurement& d,
                        DisplacementSource src);
  // UWB_RX and BLE_AOA go through the hosted estimators, which need the site: counted when none.
  bool have_site_for_raw();
  void on_tdoa_epoch(const uwb_tdoa::TdoaEpoch& e);
  void on_aoa_epoch(const aoa::AoaEpochAngles& e);
  // A pose of the hosted TDoA or AoA tracker: starts the tag's track if nothing has yet.
  void on_hosted_fix(const pose_t& m);

  PoseSink sink_;
  NoteSink note_sink_;
  std::string source_;
  std::optional<Site> site_;
  FuseParams params_;
  // ips-uwb-tdoa's clocks and blinks, ips-aoa's calibrated angles; their trackers only start
  // tracks (on_hosted_fix).
  uwb_tdoa::TdoaEstimator tdoa_;
  aoa::AoaEstimator aoa_;
  std::vector<aoa::AnchorFrame> frames_;  // per site anchor
  std::map<std::string, Track> tracks_;
  TimeGuard guard_;  // per tag
  ConsistencyMonitor consistency_;
  std::string range_setting_;  // "range_sigma_m 0.1"
  uwb_twr::TwrParams radio_;    // estimators.uwb_twr: the radios' offsets and how they are learned
  int64_t tdoa_reanchors_back_ = 0, aoa_reanchors_back_ = 0;  // the hosted guards', seen
  FuseStats stats_;
  std::string last_gap_;
  std::string last_lost_;
  std::string last_source_restart_;
  // Per tag and ignored dead-reckoning source: the source used instead when it was first ignored
  // (the note), and how many were ignored.
  struct IgnoredSource {
    DisplacementSource used = DisplacementSource::kNone;
    int64_t count = 0;
  };
  std::map<std::pair<std::string, DisplacementSource>, IgnoredSource> ignored_;
};

}  // namespace ips::fusion
