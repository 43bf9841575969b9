#pragma once
// Pedestrian dead reckoning with a hand-held phone (source 002): imu_t per device -> step_t on
// STEP and a 2D pose on POSE_PDR per step.
//   1. Alignment: the phone must first rest for init_still_s (002 section 4: an initial rest
//      window): tilt from gravity, heading from the magnetometer (TRIAD) or from the tag's start
//      heading in the site, gyro bias from the mean rate.
//   2. Attitude: OrientationEkf (orientation_ekf.hpp), with gravity and zero-rate updates while
//      still and gated magnetometer heading updates.
//   3. Steps: the vertical linear acceleration (world z, gravity removed; or the norm) through
//      StepDetector (step_detector.hpp); each step's length from the chosen model
//      (step_length.hpp).
//   4. Walking heading: the circular mean over the step of the heading of the phone's top (its
//      y axis) minus phone_yaw_offset_deg (the phone's yaw relative to the walking direction).
//   5. Position (002 (4.6)): x += SL cos(theta), y += SL sin(theta), theta from +x
//      counter-clockwise, from the tag's start position in the site.
//   6. Accelerometer only (the gyroscope NaN, as many phones and the Oxford step counter
//      dataset record): steps are counted on the norm of the specific force minus the phone's
//      own gravity, and published on STEP with heading_rad NaN (heading unknown); no POSE_PDR.
//      A device's first sample decides: with a gyroscope, later samples without one are
//      invalid; without one, a gyroscope appearing later is not used.
// Samples taken while aligning are kept and replayed through the step detector once aligned
// (with the attitude found at alignment), so the steps of a walk that starts before the
// alignment ends are counted. Gravity is the phone's own: the mean |a| of the alignment
// window, then refined (a running mean of |a| while still; always, without a gyroscope).
// Pure: takes messages, emits through callbacks, never reads a clock.
#include <functional>
#include <ips/imu_t.hpp>
#include <ips/pose_t.hpp>
#include <ips/step_t.hpp>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/consistency.hpp"
#include "core/drop_reasons.hpp"
#include "core/time_guard.hpp"
#include "core/site.hpp"
#include "estimators/pdr/orientation_ekf.hpp"
#include "estimators/pdr/step_detector.hpp"
#include "estimators/pdr/step_length.hpp"

namespace ips::pdr {

enum class StepSignal { kVertical, kNorm };

struct PdrParams {
  StepDetectorParams detector;
  StepLengthParams length;
  StepSignal signal = StepSignal::kVertical;
  EarthField field;
  OrientationNoise noise;
  bool use_magnetometer = true;
  double mag_norm_tolerance = 0.15;      // |m| within 15 % of the Earth field
  double mag_dip_tolerance_deg = 8.0;
  double mag_update_period_s = 0.5;      // at most one heading update per this ...
  double mag_update_distance_m = 2.0;    // ... and per this distance walked (disturbances are
                                         // a function of place: correlated over metres)
  double mag_gate_chi2 = kNoGate;        // innovation gate of the heading update
  // Quasi-static field check (orientation_ekf.hpp): a heading update only when, over the last
  // mag_static_window_m walked (per-step means), the world-frame field's heading varied by at
  // most mag_static_heading_deg (the magnetometer's turn agrees with the gyro's), its norm by
  // at most mag_static_norm_ut and its dip by at most mag_static_dip_deg. Window 0: off.
  double mag_static_window_m = 3.0;
  double mag_static_heading_deg = 5.0;
  double mag_static_norm_ut = 2.0;
  double mag_static_dip_deg = 3.0;
  // The disturbance's correlation length along the walk: an update this close to the previous
  // one repeats much of its error, so its variance is inflated by (1 + rho) / (1 - rho), rho =
  // exp(-d / mag_correlation_m) (d: walked since the last accepted update). 0: independent.
  double mag_correlation_m = 2.0;
  bool learn_noise = true;               // learn the magnetometer's heading noise (never below
                                         // mag_heading_sigma_deg; core/consistency.hpp)
  double phone_yaw_offset_deg = 0.0;     // phone's top relative to the walking direction, CCW
  double gravity_mps2 = 9.81;            // only to recognise rest before the phone's own is known
  double gravity_window_s = 10.0;        // time constant of the phone's own gravity estimate
  double init_still_s = 1.0;             // rest needed before the first step
  double max_align_s = 2.0;              // without rest: start after this long, from the mean
  double still_gyro_rad_s = 0.05;        // still: |omega - b| below this ...
  double still_accel_mps2 = 0.3;         // ... and ||a| - g| below this ...
  double still_window_s = 0.3;           // ... for this long
  double step_length_sigma_m = 0.05;
  double max_gap_s = 0.5;                // a larger gap between samples is not integrated
  int max_tags = 100;
};

// Reads `estimators.pdr` of the site; throws ConfigError naming file, line and field.
PdrParams parse_pdr_params(const YamlField& section);

struct PdrStats {
  int64_t samples_in = 0;
  int64_t dropped_invalid = 0;     // NaN accelerometer or gyroscope, implausible utime
  // Not after the device's previous sample: at its time (a LAN's duplicate), before it within
  // max_gap_s (reordered on the way: the next interval covers it, routine), or further back.
  int64_t dropped_repeated = 0;
  int64_t dropped_reordered = 0;
  int64_t dropped_time = 0;
  int64_t gaps = 0;                // samples after a gap longer than max_gap_s
  int64_t dropped_gap = 0;         // of those, samples of an aligned track: not integrated
  int64_t samples_aligning = 0;    // taken while aligning and lost (buffer full, IMU refused)
  int64_t samples_replayed = 0;    // taken while aligning, replayed once aligned
  int64_t accel_only_tracks = 0;   // devices without a gyroscope: steps, heading unknown
  int64_t steps_heading_unknown = 0;
  int64_t dropped_no_site = 0;
  int64_t dropped_too_many_tags = 0;
  int64_t alignments = 0;
  int64_t alignments_without_rest = 0;
  int64_t alignments_too_slow = 0;  // sample rate below 4 x the step filter's cut-off: refused
  int64_t mag_updates = 0;
  int64_t mag_rejected = 0;        // field failed the norm or dip check
  int64_t mag_gated = 0;           // of mag_updates, refused by the innovation gate
  int64_t mag_not_static = 0;      // refused: the field varied along the last metres (not
                                   // quasi-static: disturbed), checked once per step
  int64_t steps = 0;
  int64_t no_start_pose = 0;       // tags started at the origin: no start_position in the site

  // The samples that went into no step, by reason (HEALTH, ips-replay's summary).
  DropReasons drop_reasons() const {
    DropReasons d;
    d.add(DropReason::kNoSite, dropped_no_site);
    d.add(DropReason::kInvalid, dropped_invalid);
    d.add(DropReason::kDuplicate, dropped_repeated);
    d.add(DropReason::kReordered, dropped_reordered);
    d.add(DropReason::kLate, dropped_time);
    d.add(DropReason::kTooManyTags, dropped_too_many_tags);
    d.add(DropReason::kGap, dropped_gap);
    d.add(DropReason::kInitialising, samples_aligning);
    return d;
  }
};

class PdrEstimator {
 public:
  using StepSink = std::function<void(const step_t&)>;
  using PoseSink = std::function<void(const pose_t&)>;
  PdrEstimator(StepSink steps, PoseSink poses, std::string source_name = "pdr");

  void set_site(const Site& site);
  bool has_site() const { return site_.has_value(); }
  void on_imu(const imu_t& m);
  const PdrStats& stats() const { return stats_; }
  DropReasons drop_reasons() const {
    DropReasons d = stats_.drop_reasons();
    d.add(DropReason::kTimeJump, guard_.dropped());
    return d;
  }
  // Time plausibility of the inputs, per sender (core/time_guard.hpp).
  const TimeGuardStats& time_stats() const { return guard_.stats(); }
  const PdrParams& params() const { return params_; }
  // The magnetometer's heading innovations against mag_heading_sigma_deg, per device ("MAG"),
  // checked every mag_update_period_s whether or not used (used once per
  // mag_update_distance_m); refused by mag_gate_chi2: gated. Learned (learn_noise), never below
  // mag_heading_sigma_deg.
  const ConsistencyMonitor& consistency() const { return consistency_; }
  // Devices seen without a gyroscope (steps only, heading unknown), for HEALTH.
  std::vector<std::string> accel_only_devices() const;
  // The magnetometer's heading updates in words, for HEALTH's consistency text and
  // ips-replay: "MAG: 40 heading updates used, refused: 120 field not static, 2 norm/dip,
  // 0 gated".
  std::string mag_summary() const;
  // The run in words, for ips-replay's summary: "278 steps (3 counted from the walk's cadence);
  // MAG: ..." (the magnetometer's account only when a device has a gyroscope).
  std::string run_notes() const;
  // What keeps it from placing steps, in words ("" when nothing): "no gyroscope on P1: steps
  // only, heading unknown (STEP heading_known false), no POSE_PDR". For HEALTH (a lasting error)
  // and ips-replay.
  std::string problems() const;

 private:
  struct Sample {
    utime_t utime = 0;
    Eigen::Vector3d a, g, mag;
  };
  struct Track {
    bool aligned = false;
    bool accel_only = false;     // no gyroscope: steps only
    double gravity = 0;          // the phone's own |g|, m/s^2
    std::vector<Sample> pending;  // taken while aligning, replayed once aligned
    double sum_norm = 0, all_norm = 0;  // sums of |a| over the rest / since the first sample
    utime_t first_utime = 0, last_utime = 0;
    // Alignment sums over the current rest.
    Eigen::Vector3d sum_a = Eigen::Vector3d::Zero(), sum_g = Eigen::Vector3d::Zero(),
                    sum_m = Eigen::Vector3d::Zero();
    int n = 0, n_mag = 0;
    // ... and over every sample since the first: a phone that never rests is aligned on their
    // mean (walking's accelerations average out; gravity remains).
    Eigen::Vector3d all_a = Eigen::Vector3d::Zero(), all_m = Eigen::Vector3d::Zero();
    int n_all = 0, n_all_mag = 0;
    utime_t rest_start = 0;
    double sum_dt = 0;
    int n_dt = 0;
    OrientationEkf ekf;
    std::unique_ptr<StepDetector> detector;
    double still_s = 0;
    utime_t last_mag_update = 0;
    Eigen::Vector3d sum_mw = Eigen::Vector3d::Zero();  // q m since the last update
    int n_mw = 0;
    Eigen::Vector3d sum_check = Eigen::Vector3d::Zero();  // q m since the last check
    int n_check = 0;
    utime_t last_mag_check = 0;
    double mag_distance_m = 0;  // walked since the last heading update
    // Quasi-static check: the world-frame field's mean per step over the last
    // mag_static_window_m walked, with each step's length.
    Eigen::Vector3d sum_seg = Eigen::Vector3d::Zero();
    int n_seg = 0;
    std::vector<std::pair<Eigen::Vector3d, double>> segments;
    double seg_mark_m = 0;            // mag_distance_m at the last step
    double since_accepted_m = 1e9;    // walked since the last accepted heading update
    double sum_cos = 0, sum_sin = 0;  // walking heading since the last step
    Eigen::Vector2d position = Eigen::Vector2d::Zero();
    Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
    double z = 0;
    int32_t steps = 0;
  };

  void align(Track& t, const std::string& tag_id, bool rested);
  // One sample of an aligned track; `replay`: taken while aligning (no attitude update).
  void walk(Track& t, const std::string& tag_id, const Sample& m, double dt, bool replay);
  void update_mag(Track& t, const std::string& tag_id, utime_t now);
  void emit_step(Track& t, const std::string& tag_id, const DetectedStep& step, double theta);

  StepSink step_sink_;
  PoseSink pose_sink_;
  std::string source_;
  std::optional<Site> site_;
  PdrParams params_;
  std::map<std::string, Track> tracks_;
  PdrStats stats_;
  TimeGuard guard_;  // per sender (core/time_guard.hpp)
  ConsistencyMonitor consistency_;
  std::string mag_setting_;
};

}  // namespace ips::pdr
