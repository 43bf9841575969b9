#pragma once
// Foot-mounted ZUPT-aided strapdown INS (source 001 section 2, the OpenShoe ZUPT INS): imu_t
// samples of a foot-mounted IMU -> pose_t per tag (device_id).
//   1. Stance detection: the SHOE detector on acceleration and angular-rate energy over the last
//      W samples (stance_detector.hpp); a stance counts once it has lasted min_stance_s.
//   2. Initial alignment over the first still period (at least alignment_s, refined until the
//      foot first moves): roll and pitch from the mean specific force, gyro bias from the mean
//      angular rate (002 section 4), position and yaw from the tag's start pose in the site
//      (tags[].start_position, start_heading_deg: the direction of the toes; no magnetometer).
//   3. Strapdown mechanisation and a 9-state error-state Kalman filter (strapdown_filter.hpp),
//      with a zero-velocity update on every stance sample (models/zero_velocity.hpp). The
//      filter's yaw is relative to the start heading (yaw is unobservable from ZUPTs: a large
//      initial yaw variance only lets the ZUPTs turn the track spuriously); the start heading's
//      own uncertainty is added to the published covariance as a rotation about the start.
//   4. Gait check: a stance is believed when the swing before it turned the foot fast (a foot's
//      swing peaks at hundreds of deg/s; a hand-held phone's sway does not) or when it lasts
//      alignment_s. No pose while the last believed stance is more than max_swing_s ago or the
//      current stance is not believed; problems() says why after stance_timeout_s.
// Publishes at most one pose per publish_period_s: position with the filter's covariance,
// velocity, heading of the device's y axis (the toes), 3D. num_used = ZUPTs since the last
// pose, residual_m = RMS position correction they applied; COASTING when none (the swing).
// Pure: takes messages, emits pose_t through a callback, never reads a clock.
#include <functional>
#include <ips/imu_t.hpp>
#include <ips/pose_t.hpp>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/consistency.hpp"
#include "core/drop_reasons.hpp"
#include "core/time_guard.hpp"
#include "core/pose_tally.hpp"
#include "core/site.hpp"
#include "estimators/ins/stance_detector.hpp"
#include "estimators/ins/strapdown_filter.hpp"

namespace ips::ins {

struct InsParams {
  double gravity_mps2 = 9.81;
  StanceDetectorParams detector;  // 001/OpenShoe: W = 3, 0.01 m/s^2, 0.1 deg/s, 3e4
  double min_stance_s = 0.02;     // shorter stances are not trusted for a ZUPT
  double min_swing_s = 0.1;       // a shorter break of a stance is not a swing (a step's is ~0.4 s)
  double min_swing_rate_dps = 90; // a swing that never turns the foot faster is not a stride
  double max_swing_s = 5.0;       // no believed stance for longer: no pose (unaided INS)
  double stance_timeout_s = 10.0; // ... for longer (or no alignment): said in problems()
  double alignment_s = 1.0;       // still time needed before navigating (001: 50 ms)
  double accel_noise_mps2 = 0.5;  // process noise per sample (OpenShoe sigma_acc)
  double gyro_noise_rps = 0.5 * 3.14159265358979323846 / 180.0;  // OpenShoe 0.5 deg/s
  double zupt_sigma_mps = 0.01;                                  // 001: R = 1e-4 I
  double initial_position_sigma_m = 0.01;
  double initial_velocity_sigma_mps = 0.01;
  double initial_tilt_sigma_deg = 1.0;
  double initial_heading_sigma_deg = 1.0;
  double max_gap_s = 0.1;         // a longer gap between samples is not integrated
  double publish_period_s = 0.1;  // 0: a pose per sample
  int max_tags = 1000;
  // The IMUs the site says are on a foot (device ids). One of them that never shows a stance
  // phase is a fault (HEALTH degraded); any other IMU without stance phases is taken for what it
  // most likely is, a phone in hand or in a pocket: said as a note, HEALTH stays OK. Empty: no
  // IMU is declared, so none is a fault.
  std::vector<std::string> foot_imus;
};

// Reads `estimators.ins` of the site; throws ConfigError naming file, line and field.
InsParams parse_ins_params(const YamlField& section);

struct InsStats {
  int64_t samples_in = 0;
  int64_t samples_used = 0;          // integrated, or used for the alignment
  int64_t dropped_invalid = 0;       // NaN/inf or absurd accelerometer or gyro, implausible utime
  // A sample not after the tag's previous one: at its time (a LAN's duplicate), before it within
  // max_gap_s (reordered on the way: the next interval covers it, routine), or further back.
  int64_t dropped_repeated = 0;
  int64_t dropped_reordered = 0;
  int64_t dropped_out_of_order = 0;
  int64_t dropped_no_site = 0;
  int64_t dropped_too_many_tags = 0;
  int64_t gaps = 0;  // more than max_gap_s between two samples: not integrated
  int64_t samples_aligning = 0;  // taken before the tag's alignment is done: no pose yet
  int64_t alignments = 0;
  int64_t alignment_restarts = 0;       // the foot moved before alignment_s of stillness
  int64_t tags_without_start_pose = 0;  // started at the origin facing +x
  int64_t stance_samples = 0;
  int64_t zupts = 0;
  int64_t zupts_failed = 0;  // numerically singular (never expected)
  int64_t weak_swings = 0;   // swings that never reached min_swing_rate_dps (no stride)
  int64_t poses_withheld = 0;  // due but not published: no believed stance (not a foot?)
  int64_t poses_out = 0;

  // The samples that gave no pose, by reason (HEALTH, ips-replay's summary).
  DropReasons drop_reasons() const {
    DropReasons d;
    d.add(DropReason::kNoSite, dropped_no_site);
    d.add(DropReason::kInvalid, dropped_invalid);
    d.add(DropReason::kDuplicate, dropped_repeated);
    d.add(DropReason::kReordered, dropped_reordered);
    d.add(DropReason::kLate, dropped_out_of_order);
    d.add(DropReason::kTooManyTags, dropped_too_many_tags);
    d.add(DropReason::kGap, gaps);
    d.add(DropReason::kInitialising, samples_aligning);
    return d;
  }
};

// One tag's dead-reckoning summary, for tests and reports.
struct InsTrackSummary {
  bool navigating = false;
  int64_t strides = 0;    // stance phases that reached min_stance_s after the start
  double distance_m = 0;  // horizontal path between successive stance positions
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();
  double heading_rad = 0;
  Eigen::Vector3d gyro_bias_rps = Eigen::Vector3d::Zero();
  bool in_stance = false;
};

class InsEstimator {
 public:
  using PoseSink = std::function<void(const pose_t&)>;
  explicit InsEstimator(PoseSink sink, std::string source_name = "ins");

  // Parameters and start poses; resets all tracks. Throws ConfigError on bad parameters (the
  // estimator keeps its previous site then).
  void set_site(const Site& site);
  bool has_site() const { return site_.has_value(); }
  void on_imu(const imu_t& msg);

  const InsStats& stats() const { return stats_; }
  DropReasons drop_reasons() const {
    DropReasons d = stats_.drop_reasons();
    d.add(DropReason::kTimeJump, guard_.dropped());
    return d;
  }
  // Time plausibility of the inputs, per sender (core/time_guard.hpp).
  const TimeGuardStats& time_stats() const { return guard_.stats(); }
  const InsParams& params() const { return params_; }
  std::optional<InsTrackSummary> track(const std::string& tag_id) const;
  // Tags whose IMU shows no stance phases, in words ("" when none): "foot1: no foot stance
  // phase for 6.2 s (the IMU moves but never like a foot: hand-held or in a pocket?); no
  // POSE_INS". For HEALTH (a lasting error) and ips-replay.
  std::string problems() const;
  // The same split by the site's foot_imus: those declared on a foot (a fault: HEALTH's lasting
  // error) and the others (HEALTH's note: not a foot-mounted IMU, nothing to do for ips-ins).
  std::string foot_problems() const;
  std::string other_imu_notes() const;
  // The ZUPT innovations against zupt_sigma_mps, per tag (core/consistency.hpp).
  const ConsistencyMonitor& consistency() const { return consistency_; }

 private:
  enum class Phase { kAligning, kNavigating };
  // problems() of the tracks for which `declared(id)` (on the site's foot_imus) equals `foot`.
  std::string problems_of(bool all, bool foot) const;
  // Where a track starts (relative navigation cannot find it: 001 section 5).
  struct StartPose {
    Eigen::Vector3d position_m = Eigen::Vector3d::Zero();
    double heading_rad = 0.0;  // the toes' direction, from +x counter-clockwise
  };
  struct Track {
    Phase phase = Phase::kAligning;
    StanceDetector detector;
    StartPose start;
    utime_t last_utime = 0;
    // Alignment: sums over the current still period.
    Eigen::Vector3d accel_sum = Eigen::Vector3d::Zero();
    Eigen::Vector3d gyro_sum = Eigen::Vector3d::Zero();
    int64_t still_samples = 0;
    utime_t still_since = 0;
    bool refining = false;  // navigating, the first still period not over yet
    Eigen::Vector3d gyro_bias = Eigen::Vector3d::Zero();
    StrapdownFilter filter;
    bool in_stance = false;
    utime_t stance_since = 0;
    utime_t last_stance_utime = 0;  // the last stance sample
    bool stance_counted = false;
    double swing_peak_rps = 0;      // since the last stance sample
    bool stance_believed = false;   // the current (counted) stance
    utime_t last_believed_utime = 0;  // the last sample of a believed stance
    utime_t first_utime = 0;
    utime_t last_nis_utime = 0;  // the last ZUPT given to the consistency monitor
    bool have_stance_position = false;
    Eigen::Vector3d last_stance_position = Eigen::Vector3d::Zero();
    int64_t strides = 0;
    double distance_m = 0;
    bool reinitialised = false;
    PoseTally tally;
  };

  void align(Track& t);
  void navigate(Track& t, const imu_t& m, const Eigen::Vector3d& f, const Eigen::Vector3d& w,
                double dt, bool stance);
  void publish(Track& t, const std::string& tag_id, utime_t utime);
  bool gait_believed(const Track& t) const;

  PoseSink sink_;
  std::string source_;
  std::optional<Site> site_;
  InsParams params_;
  std::map<std::string, Track> tracks_;
  InsStats stats_;
  TimeGuard guard_;  // per sender (core/time_guard.hpp)
  ConsistencyMonitor consistency_;
  std::string zupt_setting_;  // "zupt_sigma_mps 0.01", as the monitor names it
};

}  // namespace ips::ins
