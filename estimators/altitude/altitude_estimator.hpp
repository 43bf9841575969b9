#pragma once
// Differential barometric altitude (../shared/reference/003_baro.md): baro_t readings of tag
// barometers and of reference stations at known heights -> altitude_t per tag on ALTITUDE.
//   1. Each reading is corrected by its sensor's calibrated offset (003 (5.2); offsets_pa, from
//      `ips-altitude calibrate`).
//   2. A tag reading is paired with the reference's pressure at the same time: interpolated
//      between the reference readings around it, waiting up to align_wait_s of message time for
//      the next one; else the newest is held, its weather drift added to the variance; older than
//      max_reference_age_s the reference is stale, the reading is not used and it is reported.
//   3. A Kalman filter on height and vertical speed (constant velocity, white-noise acceleration)
//      takes the tag's pressure as a measurement through the hypsometric equation with virtual
//      temperature (models/baro_height.hpp: 003 (4.31)-(4.32)), with the reference's measured
//      temperature (003: 7 cm per 10 C at 2 m, not negligible) and its humidity, else a constant
//      humidity (003: 50 %). Low lag: 003's 150-sample moving average delays by 7.5 s.
//   4. Still or moving (issue 22): beside the constant-velocity filter runs a "still" model, a
//      constant height averaged over still_window_s (a height random walk whose steady-state
//      averaging time is that window). A change detector on the still model's innovations (their
//      mean over motion_window_s against the spread such means showed while still, learned per
//      tag) switches to the moving model when a real change starts, and back once the still
//      model has held for still_after_s and the vertical speed is no longer significant. Still:
//      the still model's height, vertical speed 0; moving: the constant-velocity filter's.
//      The published sigma adds what the filters cannot see: the sensor's slow wander (the
//      learned spread of those means beyond white noise) and the reference's drift.
//   5. Optionally the floor (floor_detector.hpp) from the floor heights in the site.
// Pure: takes messages, emits altitude_t through a callback, never reads a clock.
#include <cmath>
#include <deque>
#include <functional>
#include <ips/altitude_t.hpp>
#include <ips/baro_t.hpp>
#include <map>
#include <optional>
#include <string>
#include <tuple>
#include <utility>

#include "core/consistency.hpp"
#include "core/cv_filter.hpp"
#include "core/drop_reasons.hpp"
#include "core/time_guard.hpp"
#include "core/site.hpp"
#include "estimators/altitude/floor_detector.hpp"
#include "estimators/altitude/reference_series.hpp"

namespace ips::altitude {

// One barometer's settings (estimators.altitude.sensors.<id>): its type gives a default noise
// from its data sheet (sensor_type_sigma_pa); pressure_sigma_pa overrides it.
struct SensorParams {
  std::string type;                // BMP180, BMP280, BMP390, MPL115A1, or empty
  int oversampling = -1;           // BMP180: its oss 0..3 (unset: its quietest's figure)
  double pressure_sigma_pa = NAN;  // one reading's RMS noise; NaN: from the type
  double rate_hz = NAN;            // readings per second; NaN: measured from the stamps
};

// The data sheet's RMS pressure noise of one reading of a known type (oversampling: BMP180's
// oss; -1: its quietest mode's), or NaN for an unknown type. docs/site-file.md cites them.
double sensor_type_sigma_pa(const std::string& type, int oversampling);

struct AltitudeParams {
  std::string reference;                    // preferred station id; empty: the freshest
  std::map<std::string, double> offsets_pa;  // per sensor id, subtracted from its readings
  double humidity_pct = 50.0;     // when the reference does not measure it (003's EKF: 50 %)
  double temperature_c = 20.0;    // when neither the reference nor the tag reports one
  double gravity_mps2 = 9.81;     // 003: a constant g
  double pressure_sigma_pa = 0.5;  // one tag reading against the reference (2 x BMP280: 0.28)
  double accel_sigma_mps2 = 0.5;   // white-noise vertical acceleration: PSD sigma^2 per Hz
  double initial_speed_sigma_mps = 0.5;
  double gate_sigma = 5.0;         // innovations beyond this many sigmas are rejected
  int max_rejections = 20;         // consecutive rejections before the track restarts
  double align_wait_s = 0.5;       // a tag reading waits this long for the next reference one
  double max_reference_age_s = 10.0;
  double reference_drift_pa_per_s = 0.03;  // a held reference's drift (a front: 100 Pa/h)
  double max_gap_s = 5.0;          // a longer gap between a tag's readings restarts its track
  double publish_period_s = 0.0;   // 0: one altitude per tag reading
  FloorParams floors;
  int max_tags = 1000;
  std::map<std::string, SensorParams> sensors;  // per sensor id
  bool learn_noise = true;  // each sensor's pressure noise learned online (core/consistency.hpp)
  // "differential" (against a reference station), "relative" (each tag's height from its own
  // first readings: single-barometer mode), or "auto": relative when the site has no baro
  // station and names no reference.
  std::string mode = "auto";
  double relative_start_s = 1.0;  // relative mode: the first readings averaged for height 0
  // Still/moving detection (step 4 above). still_window_s 0: the constant-velocity filter only.
  double still_window_s = 120.0;  // averaging time of a still tag's height
  double motion_window_s = 1.0;   // innovations averaged by the change detector
  double motion_sigma = 4.0;      // their mean beyond this many learned sigmas: moving
  double still_after_s = 10.0;    // moving ends after this long with no change seen
  double wander_learn_s = 30.0;   // the learned spread of the means rises over this (falls 10x slower)

  // The configured noise of one reading of `sensor_id` (its own setting, else its type's data
  // sheet figure, else pressure_sigma_pa), and the setting's name as the user writes it.
  double sigma_pa(const std::string& sensor_id) const;
  std::string sigma_setting(const std::string& sensor_id) const;
};

// Reads `estimators.altitude` of the site; throws ConfigError naming file, line and field.
AltitudeParams parse_altitude_params(const YamlField& section);

struct AltitudeStats {
  int64_t readings_in = 0;
  int64_t tag_readings = 0;
  int64_t reference_readings = 0;
  int64_t used = 0;      // tag readings the filter took
  int64_t rejected = 0;  // beyond the gate
  int64_t restarts = 0;  // after max_rejections or a gap
  int64_t dropped_invalid = 0;       // no id, implausible time, pressure, temperature or humidity
  int64_t dropped_out_of_order = 0;  // not after the same sensor's previous reading
  int64_t dropped_duplicate = 0;     // the previous reading again, its stamp and values alike
  int64_t dropped_no_site = 0;
  int64_t dropped_too_many_tags = 0;
  int64_t dropped_reference_without_height = 0;  // neither known_height_m nor a site station
  int64_t dropped_no_reference = 0;              // no reference station heard yet
  int64_t dropped_stale_reference = 0;           // the reference's newest reading too old
  int64_t reference_switches = 0;
  int64_t retimed = 0;  // readings sharing their sensor's previous stamp, spread at its rate
  int64_t altitudes_out = 0;
  int64_t motion_starts = 0;  // still -> moving switches of the change detector

  // The readings that gave no altitude, by reason (HEALTH, ips-replay's summary); a reference
  // station's readings are used, not dropped, though they give no altitude of their own.
  DropReasons drop_reasons() const {
    DropReasons d;
    d.add(DropReason::kNoSite, dropped_no_site);
    d.add(DropReason::kInvalid, dropped_invalid);
    d.add(DropReason::kLate, dropped_out_of_order);
    d.add(DropReason::kDuplicate, dropped_duplicate);
    d.add(DropReason::kTooManyTags, dropped_too_many_tags);
    d.add(DropReason::kReferenceWithoutHeight, dropped_reference_without_height);
    d.add(DropReason::kNoReference, dropped_no_reference);
    d.add(DropReason::kStaleReference, dropped_stale_reference);
    d.add(DropReason::kGated, rejected);
    return d;
  }
};

class AltitudeEstimator {
 public:
  using AltitudeSink = std::function<void(const altitude_t&)>;
  explicit AltitudeEstimator(AltitudeSink sink, std::string source_name = "altitude");

  // Parameters and station heights; resets all tracks. Throws ConfigError on bad parameters
  // (the estimator keeps its previous site then).
  void set_site(const Site& site);
  bool has_site() const { return site_.has_value(); }
  void on_baro(const baro_t& msg);
  // End of input (replay): tag readings still waiting for a reference reading are used with the
  // newest one.
  void finish();

  // The run in words, for ips-replay's summary: "3 changes of height detected (still ->
  // moving)".
  std::string run_notes() const {
    return std::to_string(stats_.motion_starts) + " changes of height detected (still -> moving)";
  }
  const AltitudeStats& stats() const { return stats_; }
  DropReasons drop_reasons() const {
    DropReasons d = stats_.drop_reasons();
    d.add(DropReason::kTimeJump, guard_.dropped());
    return d;
  }
  // Time plausibility of the inputs, per sender (core/time_guard.hpp).
  const TimeGuardStats& time_stats() const { return guard_.stats(); }
  const AltitudeParams& params() const { return params_; }
  // Innovations of every tag reading against the noise assumed for it, per sensor ("BARO").
  const ConsistencyMonitor& consistency() const { return consistency_; }
  // Relative mode (no reference station): heights are changes since each tag's first readings.
  bool relative() const { return relative_; }
  // The latest reference problem, e.g. "reference B1 stale: its newest reading is 12.3 s older
  // than T1's"; empty when there was none. Cleared by take_problem().
  std::string take_problem() { return std::exchange(problem_, std::string()); }

 private:
  struct TagReading {
    utime_t utime;
    double pressure_pa;  // offset-corrected
    double temperature_c;
  };
  struct Track {
    std::deque<TagReading> pending;  // waiting for the reference to cover their time
    utime_t last_in_utime = 0;
    bool initialised = false;
    utime_t last_utime = 0;
    CvFilter<1> filter;  // height, vertical speed
    int rejections = 0;
    std::string reference_id;
    FloorDetector floor;
    utime_t last_publish_utime = 0;
    // Relative mode: the mean of the first relative_start_s of readings is height 0.
    bool have_start = false;
    double start_pressure_pa = 0;
    double start_temperature_c = NAN;
    utime_t start_utime = 0;
    double bias_var_m2 = 0;  // the reference's bias variance, in the published sigma
    // The still model (a constant height averaged over still_window_s) and the detector.
    bool moving = false;
    double still_h = 0, still_var = 0;  // m, m^2
    utime_t mode_utime = 0;     // the latest switch or detection
    utime_t slow_since = 0;     // moving: since when the speed is not significant; 0: it is
    std::deque<std::pair<utime_t, double>> window;  // the still model's innovations, m
    double window_sum = 0;
    double mean_var = NAN;    // learned variance of the window's mean while still, m^2
    double detect_var = NAN;  // the same, quick to rise and slow to fall: the detector's
    double mean_lean = 0;     // the means' own average: a one-sided lean is a slow change
    // Relative mode, until the first motion: the largest distance seen between the start level
    // and the still model's long average, m^2 (a warm-up transient in the first readings).
    bool moved = false;
    double start_error_m2 = 0;
    std::deque<std::tuple<utime_t, double, double>> moving_h;  // moving: time, height, P00
    double wander_var = 0;  // its part beyond white noise: the sensor's slow wander, m^2
  };
  // Per sensor: its readings' stamps, to spread readings that share one at the sensor's rate.
  struct Timing {
    utime_t first_stamp = 0, last_stamp = 0, last_time = 0;
    int64_t distinct = 0;  // readings with a stamp of their own
    uint64_t last_content = 0;  // the previous reading's values (repeat_key), to know a copy
  };
  struct Station {
    ReferenceSeries series;
    utime_t last_in_utime = 0;
  };

  // The time of a reading: its stamp, or, when it shares its sensor's previous stamp (several
  // lines read at once), the previous reading's time plus one period. 0: out of order;
  // kCopyOfPrevious: the previous reading again, stamp and values (`content`), a LAN's copy.
  static constexpr utime_t kCopyOfPrevious = -1;
  utime_t reading_time(const std::string& sensor_id, utime_t stamp, uint64_t content);
  void accept(const baro_t& m);  // a valid reading at its (possibly spread) time
  void on_reference(const baro_t& m, double pressure_pa);
  void on_tag(const baro_t& m, double pressure_pa);
  // Uses every pending reading whose reference is there, or which has waited long enough.
  void drain(bool flush);
  // The reference station to use at time t (the preferred one, else the freshest), or nullptr.
  const std::pair<const std::string, Station>* pick_reference(utime_t t) const;
  // Fuses one tag reading against `station` (pick_reference's choice at its time; nullptr: none).
  void use(const std::string& tag_id, Track& t, const TagReading& r,
           const std::pair<const std::string, Station>* station);
  // The still model and the change detector on one used reading: z the reading's height, r_m2
  // its variance, dt_s since the track's previous reading.
  void still_update(Track& t, utime_t utime, double dt_s, double z, double r_m2);
  void restart_still(Track& t, utime_t utime) const;
  void publish(const std::string& tag_id, Track& t, utime_t utime);

  AltitudeSink sink_;
  std::string source_;
  std::optional<Site> site_;
  AltitudeParams params_;
  std::map<std::string, Track> tracks_;
  std::map<std::string, Station> stations_;
  utime_t newest_utime_ = 0;  // message time: the newest reading of any sensor
  AltitudeStats stats_;
  TimeGuard guard_;  // per sender (core/time_guard.hpp)
  std::map<std::string, Timing> timing_;
  ConsistencyMonitor consistency_;
  bool relative_ = false;
  std::string problem_;
};

}  // namespace ips::altitude
