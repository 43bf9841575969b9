// A phone or foot-mounted IMU carried by every walker (imu_t on IMU): accelerometer (specific
// force, gravity included: +9.81 m/s^2 on z when level), gyroscope and magnetometer in the
// device frame, from a walking model driven by the walker's trajectory.
//
// Device frame: Android's (x right, y top, z out of the screen), as in
// ../shared/reference/002_pdr.md section 1. `mount: hand` holds the phone screen up with its top
// along the walking direction (plus a configurable yaw offset, tilt and a slow yaw swing);
// `mount: foot` straps it on the instep, y towards the toes.
//
// Kinematics. The trajectory turns and starts instantly, which no body does, so the IMU follows
// the trajectory box-averaged over `smoothing_s`: velocity (p(t+T/2) - p(t-T/2)) / T, heading
// the box mean of the unwrapped leg heading, distance walked the box mean of distance_m. The
// smoothed path stays on the true one along straight legs and cuts corners by at most ~T*v/4.
// Accelerations and angular rates are finite differences of the sampled velocity and
// orientation, so a strapdown integration of noise-free output (rotation by the exact
// exponential, velocity by Euler) reproduces the model's velocity and orientation exactly.
//
// Steps (002 section 2.2). The step phase is distance walked / step_length_m, so the number of
// steps is distance / step length and nothing steps while the walker stands; the cadence is
// speed / step length (1.8 Hz at 1.3 m/s with 0.72 m).
// - hand: vertical acceleration A cos(2 pi phase), one peak per step; a forward component at the
//   step frequency and a lateral sway at half of it (one per stride), all faded in and out with
//   the fraction of the smoothing window spent moving. A defaults to half the (a_max - a_min) that
//   002's Weinberg calibration, SL = (a_max - a_min)^(1/4) - 0.828, gives for the step length
//   (2.87 m/s^2 for 0.72 m), so ips-pdr's Weinberg model recovers the configured step length.
//   Simplification: an acceleration, not a displacement, so a walk ending mid-step leaves a small
//   velocity offset in double integration (a hand-held PDR never double-integrates).
// - foot (the ZUPT-INS of 001 section 2): each stride (two steps) is a stance phase, the foot flat
//   and still (velocity exactly zero: specific force = gravity, gyro = bias + noise, except while
//   the walker pivots round a corner), then a swing of `swing_fraction` of the stride that moves
//   the foot one stride forward along the walking direction with a smooth (zero velocity and
//   acceleration at both ends) profile, lifts it `foot_lift_m` and pitches it toe down then toe
//   up by `foot_pitch_deg`. Strides are stretched to fit a whole number between two stops, so
//   the foot is down whenever the walker stands (the step count is then distance / step length
//   to within a stride per stretch). Simplifications: no heel-strike shock, no roll, the foot
//   moves along the smoothed walking direction; on stairs it climbs during swings only.
//
// Errors: Gaussian white noise per sample on every axis; constant biases (a configured vector
// plus a per-device random part); the magnetometer sees the Earth's field (magnitude, dip,
// declination; the site frame is taken as 002's local frame, x East, y North, z up) plus indoor
// disturbances: a smooth random field (random Fourier modes with a Gaussian correlation of length
// `mag_disturbance_length_m`, the same building field for every walker) and listed anomaly zones
// (a bump of field_ut that fades to zero at radius_m). device_utime is the phone's own clock:
// its uptime at the scenario start plus the elapsed time, optionally drifting.
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <ips/imu_t.hpp>
#include <limits>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

#include "drivers/sim/sensor_model.hpp"

namespace ips::sim {

namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kGravity = 9.81;      // m/s^2, 002's value for gravity removal
constexpr double kWeinbergK2 = 0.828;  // 002 Table 3.1 calibration, SL = da^(1/4) - 0.828
constexpr double kDeg = kPi / 180.0;
constexpr int kDisturbanceModes = 16;

enum class Mount { kHand, kFoot };

struct MagAnomaly {
  Eigen::Vector2d at;        // horizontal centre (the zone spans all heights: a pillar, a radiator)
  double radius_m;           // the bump is zero from here on
  Eigen::Vector3d field_ut;  // added at the centre, site frame
};

struct ImuParams {
  double rate_hz = 100.0;
  double mag_rate_hz = 100.0;  // magnetometer samples per second; the others carry NaN
  Mount mount = Mount::kHand;
  double step_length_m = 0.72;
  double smoothing_s = 1.0;
  // hand
  double vertical_amplitude_mps2 = 0;  // set from the step length (Weinberg) unless given
  double forward_amplitude_mps2 = 1.0;
  double lateral_amplitude_mps2 = 0.4;
  double yaw_swing_deg = 0.0;  // the phone turned to and fro in the hand
  double yaw_swing_period_s = 20.0;
  // foot
  double swing_fraction = 0.4;  // of a stride; 40 % is the textbook swing phase of walking
  double foot_lift_m = 0.10;
  double foot_pitch_deg = 30.0;
  // mounting
  double yaw_offset_deg = 0.0;
  double pitch_deg = 0.0;  // about device x: top edge up
  double roll_deg = 0.0;   // about device y
  // Sensor errors. Noise: LSM6DS3 (002's phone) datasheet densities, 90 ug/sqrt(Hz) and
  // 7 mdps/sqrt(Hz), over the 200 Hz bandwidth of its 400 Hz rate. Biases: after the phone's
  // factory calibration; 002 found the "uncalibrated" gyro drifts within seconds.
  double accel_noise_mps2 = 0.0125;
  Eigen::Vector3d accel_bias_mps2 = Eigen::Vector3d::Zero();
  double accel_bias_sigma_mps2 = 0.05;
  double gyro_noise_rps = 0.0017;
  Eigen::Vector3d gyro_bias_rps = Eigen::Vector3d::Zero();
  double gyro_bias_sigma_rps = 0.005;
  // Magnetometer. Dip 66 deg and declination 4.82 deg E: Prague, 002 section 2.4/2.6.
  double mag_field_ut = 50.0;
  double mag_inclination_deg = 66.0;
  double mag_declination_deg = 4.82;
  double mag_noise_ut = 0.4;  // AK09918-class phone magnetometer (0.15 uT/LSB)
  double mag_disturbance_ut = 3.0;
  double mag_disturbance_length_m = 2.0;
  std::vector<MagAnomaly> mag_anomalies;
  // Device clock
  double device_clock_offset_s = std::numeric_limits<double>::quiet_NaN();  // NaN: random uptime
  double device_clock_drift_ppm = 0.0;
};

// The magnetic field in the site frame: Earth's field plus the building's disturbances.
class MagneticField {
 public:
  MagneticField(const ImuParams& p, std::mt19937_64 rng) : anomalies_(p.mag_anomalies) {
    const double inc = p.mag_inclination_deg * kDeg, dec = p.mag_declination_deg * kDeg;
    // ENU: north component cos(I) towards magnetic north (declination D east of y), down sin(I).
    earth_ = p.mag_field_ut * Eigen::Vector3d(std::sin(dec) * std::cos(inc),
                                              std::cos(dec) * std::cos(inc), -std::sin(inc));
    // Random Fourier features: wave vectors ~ N(0, I / L^2) give the covariance
    // sigma^2 exp(-|dp|^2 / (2 L^2)) per axis. Amplitudes are scaled so that each axis has
    // exactly the configured variance, so a short scenario is not luckily quiet.
    std::normal_distribution<double> gauss(0.0, 1.0);
    std::uniform_real_distribution<double> uni(0.0, 2.0 * kPi);
    Eigen::Vector3d power = Eigen::Vector3d::Zero();
    for (auto& m : modes_) {
      for (int i = 0; i < 3; ++i) m.k[i] = gauss(rng) / p.mag_disturbance_length_m;
      for (int i = 0; i < 3; ++i) m.amplitude[i] = gauss(rng);
      m.phase = uni(rng);
      power += 0.5 * m.amplitude.cwiseAbs2();
    }
    for (auto& m : modes_)
      for (int i = 0; i < 3; ++i)
        m.amplitude[i] *= power[i] > 0 ? p.mag_disturbance_ut / std::sqrt(power[i]) : 0.0;
  }

  Eigen::Vector3d at(const Eigen::Vector3d& p) const {
    Eigen::Vector3d b = earth_;
    for (const auto& m : modes_) b += m.amplitude * std::cos(m.k.dot(p) + m.phase);
    for (const auto& a : anomalies_) {
      const double r2 = (p.head<2>() - a.at).squaredNorm() / (a.radius_m * a.radius_m);
      if (r2 < 1.0) b += (1.0 - r2) * (1.0 - r2) * a.field_ut;  // C1 bump, zero outside
    }
    return b;
  }

 private:
  struct Mode {
    Eigen::Vector3d k;
    Eigen::Vector3d amplitude;
    double phase;
  };
  Eigen::Vector3d earth_;
  std::array<Mode, kDisturbanceModes> modes_;
  std::vector<MagAnomaly> anomalies_;
};

double wrap_pi(double a) { return a - 2.0 * kPi * std::floor((a + kPi) / (2.0 * kPi)); }

class ImuSource : public PeriodicSource {
 public:
  ImuSource(const ImuParams& p, std::shared_ptr<const MagneticField> field,
            const TagTrajectory& walker, std::mt19937_64 rng)
      : PeriodicSource(period_us(p.rate_hz), 0),
        p_(p),
        field_(std::move(field)),
        walker_(walker),
        rng_(std::move(rng)),
        period_us_(period_us(p.rate_hz)),
        dt_(static_cast<double>(period_us_) * 1e-6),
        window_(std::max<size_t>(2, static_cast<size_t>(std::lround(p.smoothing_s / dt_)))),
        half_window_s_(0.5 * static_cast<double>(window_) * dt_),
        mag_ratio_(p.mag_rate_hz / p.rate_hz) {
    std::normal_distribution<double> gauss(0.0, 1.0);
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    for (int i = 0; i < 3; ++i)
      accel_bias_[i] = p_.accel_bias_mps2[i] + p_.accel_bias_sigma_mps2 * gauss(rng_);
    for (int i = 0; i < 3; ++i)
      gyro_bias_[i] = p_.gyro_bias_rps[i] + p_.gyro_bias_sigma_rps * gauss(rng_);
    // A phone's sensor clock counts from boot: up between 1 minute and 1 day at the start.
    const double uptime_s = 60.0 + uni(rng_) * 86340.0;
    clock_offset_us_ =
        s_to_utime(std::isnan(p_.device_clock_offset_s) ? uptime_s : p_.device_clock_offset_s);

    if (p_.mount == Mount::kFoot) find_stops();
    // Standing at the start before t = 0; then run the window through the samples before t = 0 so
    // that sample 0 sees a history at rest (all finite differences start from zero).
    const TrajectoryState s0 = walker_.path.at(-1.0);
    raw_heading_ = unwrapped_heading_ = heading_mean_ = s0.heading_rad;
    distance_mean_ = s0.distance_m;
    ring_.assign(window_, {s0.position, s0.distance_m, s0.heading_rad, false});
    orientation_ = device_orientation(-1.0, 0.0);
    for (int64_t k = -static_cast<int64_t>(window_); k < 0; ++k)
      advance(static_cast<double>(k) * dt_);
  }

 protected:
  bool emit(utime_t t, double t_s, SimEvent& ev) override {
    advance(t_s);
    std::normal_distribution<double> gauss(0.0, 1.0);
    // Nine draws per sample whatever is published, so the stream stays aligned.
    Eigen::Vector3d na, ng, nm;
    for (int i = 0; i < 3; ++i) na[i] = gauss(rng_);
    for (int i = 0; i < 3; ++i) ng[i] = gauss(rng_);
    for (int i = 0; i < 3; ++i) nm[i] = gauss(rng_);

    imu_t m;
    m.utime = t;
    m.source = kSimSource;
    m.device_id = walker_.tag_id;
    const int64_t elapsed_us = static_cast<int64_t>(count_) * period_us_;
    m.device_utime =
        clock_offset_us_ + elapsed_us +
        std::llround(static_cast<double>(elapsed_us) * p_.device_clock_drift_ppm * 1e-6);
    const Eigen::Vector3d accel = specific_force_ + accel_bias_ + p_.accel_noise_mps2 * na;
    const Eigen::Vector3d gyro = angular_rate_ + gyro_bias_ + p_.gyro_noise_rps * ng;
    for (int i = 0; i < 3; ++i) {
      m.accel[i] = accel[i];
      m.gyro[i] = gyro[i];
      m.mag_ut[i] = std::numeric_limits<double>::quiet_NaN();
    }
    // Magnetometer samples at mag_rate_hz: sample k carries one when floor(k * ratio) steps.
    const double kd = static_cast<double>(count_);
    if (mag_ratio_ > 0 &&
        (count_ == 0 || std::floor(kd * mag_ratio_) != std::floor((kd - 1) * mag_ratio_))) {
      const Eigen::Vector3d b =
          orientation_.conjugate() * field_->at(walker_.path.at(t_s).position) +
          p_.mag_noise_ut * nm;
      for (int i = 0; i < 3; ++i) m.mag_ut[i] = b[i];
    }
    ++count_;
    encode_event(m, t, "IMU", ev);
    return true;
  }

 private:
  struct Sample {  // the trajectory half a window ahead of a sample
    Eigen::Vector3d position;
    double distance_m;
    double heading_rad;  // unwrapped
    bool moving;
  };

  Eigen::Quaterniond device_orientation(double t_s, double foot_pitch_rad) const {
    double yaw = heading_mean_ + p_.yaw_offset_deg * kDeg - kPi / 2;  // device y along the walk
    if (p_.yaw_swing_deg != 0)
      yaw += p_.yaw_swing_deg * kDeg * std::sin(2 * kPi * t_s / p_.yaw_swing_period_s);
    return Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
           Eigen::AngleAxisd(foot_pitch_rad + p_.pitch_deg * kDeg, Eigen::Vector3d::UnitX()) *
           Eigen::AngleAxisd(p_.roll_deg * kDeg, Eigen::Vector3d::UnitY());
  }

  // Foot: the distances (within a lap of a loop) at which the walker comes to a stop, found by
  // sampling one pass or lap every 50 ms (shorter stops do not matter with the smoothing).
  void find_stops() {
    const WaypointTrajectory& path = walker_.path;
    const double length = path.length_m();
    const double step = std::max(0.05, path.lap_s() / 1e6);
    const auto samples = static_cast<int64_t>(std::ceil(path.lap_s() / step)) + 2;
    bool was_moving = false;
    for (int64_t i = 0; i <= samples; ++i) {
      const TrajectoryState st = path.at(path.start_s() + static_cast<double>(i) * step);
      if (was_moving && !st.moving) {
        double d = st.distance_m;
        if (path.loop() && length > 0)
          d -= length * std::floor((d - 1e-9) / length);  // (0, length]
        stops_.push_back(d);
      }
      was_moving = st.moving;
    }
    std::sort(stops_.begin(), stops_.end());
  }

  // The stretch of path between the stops round distance s (the start of the walk counts as one):
  // where it begins, and the length of each of the whole number of strides that fill it.
  void stride_between_stops(double s, double& from, double& stride_m) const {
    const double nominal = 2 * p_.step_length_m;
    const WaypointTrajectory& path = walker_.path;
    double lo = 0, hi = std::numeric_limits<double>::infinity();
    if (!stops_.empty()) {
      const double length = path.length_m();
      const double lap = path.loop() && length > 0 ? std::floor(s / length) : 0.0;
      const double base = lap * length;
      const auto next = std::upper_bound(stops_.begin(), stops_.end(), s - base);
      if (next != stops_.end()) {
        hi = base + *next;
      } else if (path.loop()) {
        hi = base + length + stops_.front();
      }
      if (next != stops_.begin()) {
        lo = base + *std::prev(next);
      } else if (path.loop() && lap > 0) {
        lo = base - length + stops_.back();
      }
    }
    from = lo;
    stride_m =
        std::isinf(hi) ? nominal : (hi - lo) / std::max(1.0, std::round((hi - lo) / nominal));
    if (!(stride_m > 0)) stride_m = nominal;
  }

  // Moves the model to the sample at t_s (one sample after the previous call) and sets
  // specific_force_, angular_rate_ and orientation_.
  void advance(double t_s) {
    const TrajectoryState ahead = walker_.path.at(t_s + half_window_s_);
    unwrapped_heading_ += wrap_pi(ahead.heading_rad - raw_heading_);
    raw_heading_ = ahead.heading_rad;
    Sample& slot = ring_[head_];
    const Sample oldest = slot;
    slot = {ahead.position, ahead.distance_m, unwrapped_heading_, ahead.moving};
    head_ = (head_ + 1) % window_;
    const double n = static_cast<double>(window_);
    distance_mean_ += (slot.distance_m - oldest.distance_m) / n;
    heading_mean_ += (slot.heading_rad - oldest.heading_rad) / n;
    moving_count_ += static_cast<int>(slot.moving) - static_cast<int>(oldest.moving);
    const Eigen::Vector3d body_velocity = (slot.position - oldest.position) / (n * dt_);
    const double moving_fraction = moving_count_ / n;
    const double step_phase = distance_mean_ / p_.step_length_m;  // steps walked
    const Eigen::Vector3d forward(std::cos(heading_mean_), std::sin(heading_mean_), 0.0);
    const Eigen::Vector3d left(-forward.y(), forward.x(), 0.0);

    Eigen::Vector3d velocity;
    Eigen::Vector3d accel_extra = Eigen::Vector3d::Zero();
    double foot_pitch = 0.0;
    if (p_.mount == Mount::kHand) {
      velocity = body_velocity;
      const double w = 2 * kPi * step_phase;
      accel_extra =
          moving_fraction * (p_.vertical_amplitude_mps2 * std::cos(w) * Eigen::Vector3d::UnitZ() +
                             p_.forward_amplitude_mps2 * std::sin(w) * forward +
                             p_.lateral_amplitude_mps2 * std::sin(w / 2) * left);
    } else {
      // One foot: a stride is two steps, stance first, then the swing. Strides are stretched to
      // fit a whole number between stops, so that the foot is down whenever the walker stands.
      double from = 0, stride_m = 2 * p_.step_length_m;
      stride_between_stops(distance_mean_, from, stride_m);
      const double stride = (distance_mean_ - from) / stride_m;
      const double whole = std::floor(stride);
      const double stance = 1.0 - p_.swing_fraction;
      const double tau = std::max(0.0, (stride - whole - stance) / p_.swing_fraction);
      const bool swing = tau > 0;
      // Forward profile tau - sin(2 pi tau)/(2 pi): zero velocity and acceleration at both ends.
      const double along = from + stride_m * (whole + tau - std::sin(2 * kPi * tau) / (2 * kPi));
      const double lift = 0.5 * p_.foot_lift_m * (1 - std::cos(2 * kPi * tau));
      foot_pitch =
          -p_.foot_pitch_deg * kDeg * std::sin(2 * kPi * tau);  // toe off, then heel strike
      velocity = (along - foot_along_) / dt_ * forward;
      velocity.z() =
          (lift - foot_lift_) / dt_ + (swing ? body_velocity.z() / p_.swing_fraction : 0.0);
      foot_along_ = along;
      foot_lift_ = lift;
    }
    const Eigen::Vector3d accel_nav =
        (velocity - velocity_) / dt_ + accel_extra + kGravity * Eigen::Vector3d::UnitZ();
    velocity_ = velocity;
    const Eigen::Quaterniond q = device_orientation(t_s, foot_pitch);
    const Eigen::AngleAxisd turn(orientation_.conjugate() * q);  // body-frame rotation this sample
    angular_rate_ = turn.angle() / dt_ * turn.axis();
    orientation_ = q;
    specific_force_ = q.conjugate() * accel_nav;
  }

  ImuParams p_;
  std::shared_ptr<const MagneticField> field_;  // one building field, shared by all walkers
  const TagTrajectory& walker_;
  std::mt19937_64 rng_;
  int64_t period_us_;
  double dt_;
  size_t window_;
  double half_window_s_;
  double mag_ratio_;
  Eigen::Vector3d accel_bias_, gyro_bias_;
  int64_t clock_offset_us_ = 0;
  int64_t count_ = 0;

  std::vector<Sample> ring_;  // the last window_ samples ahead; ring_[head_] is the oldest
  size_t head_ = 0;
  double raw_heading_ = 0, unwrapped_heading_ = 0;
  double distance_mean_ = 0, heading_mean_ = 0;
  int moving_count_ = 0;
  Eigen::Vector3d velocity_ = Eigen::Vector3d::Zero();
  double foot_along_ = 0, foot_lift_ = 0;
  std::vector<double> stops_;  // foot: stop distances, sorted
  Eigen::Quaterniond orientation_ = Eigen::Quaterniond::Identity();
  Eigen::Vector3d specific_force_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d angular_rate_ = Eigen::Vector3d::Zero();
};

Eigen::Vector3d vec3_param(const YamlField& f, const char* key, double limit) {
  if (!f[key].defined()) return Eigen::Vector3d::Zero();
  const Eigen::Vector3d v = f[key].as_vec3();
  if (!(v.cwiseAbs().maxCoeff() <= limit))
    f[key].fail("components must be in [-" + std::to_string(static_cast<int>(limit)) + ", " +
                std::to_string(static_cast<int>(limit)) + "]");
  return v;
}

std::vector<MagAnomaly> parse_anomalies(const YamlField& f) {
  std::vector<MagAnomaly> out;
  if (!f.defined()) return out;
  if (!f.is_sequence()) f.fail("expected a list of {at: [x, y], radius_m: R, field_ut: [x, y, z]}");
  for (size_t i = 0; i < f.size(); ++i) {
    const YamlField a = f[i];
    if (!a.is_map()) a.fail("expected {at: [x, y], radius_m: R, field_ut: [x, y, z]}");
    a.check_keys({"at", "radius_m", "field_ut"});
    MagAnomaly m;
    m.at = a.required("at").as_vec2();
    if (!(m.at.cwiseAbs().maxCoeff() <= 1e6)) a["at"].fail("coordinates must be within 1e6 m");
    a.required("radius_m");
    m.radius_m = param_in_range(a, "radius_m", 1.0, 0.01, 1000);
    a.required("field_ut");
    m.field_ut = vec3_param(a, "field_ut", 1000);
    out.push_back(m);
  }
  return out;
}

SourceList make(const YamlField& f, const SimWorld& world) {
  f.check_keys({"enabled",
                "rate_hz",
                "mag_rate_hz",
                "mount",
                "step_length_m",
                "smoothing_s",
                "vertical_amplitude_mps2",
                "forward_amplitude_mps2",
                "lateral_amplitude_mps2",
                "yaw_swing_deg",
                "yaw_swing_period_s",
                "swing_fraction",
                "foot_lift_m",
                "foot_pitch_deg",
                "yaw_offset_deg",
                "pitch_deg",
                "roll_deg",
                "accel_noise_mps2",
                "accel_bias_mps2",
                "accel_bias_sigma_mps2",
                "gyro_noise_rps",
                "gyro_bias_rps",
                "gyro_bias_sigma_rps",
                "mag_field_ut",
                "mag_inclination_deg",
                "mag_declination_deg",
                "mag_noise_ut",
                "mag_disturbance_ut",
                "mag_disturbance_length_m",
                "mag_anomalies",
                "device_clock_offset_s",
                "device_clock_drift_ppm"});
  ImuParams p;
  p.rate_hz = param_in_range(f, "rate_hz", p.rate_hz, 10, 1000);
  p.mag_rate_hz = param_in_range(f, "mag_rate_hz", std::min(p.rate_hz, 100.0), 0, p.rate_hz);
  const std::string mount = f.get_string("mount", "hand");
  if (mount == "foot") {
    p.mount = Mount::kFoot;
  } else if (mount != "hand") {
    f["mount"].fail("expected hand or foot, got '" + mount + "'");
  }
  for (const char* key : {"vertical_amplitude_mps2", "forward_amplitude_mps2",
                          "lateral_amplitude_mps2", "yaw_swing_deg", "yaw_swing_period_s"})
    if (p.mount != Mount::kHand && f[key].defined()) f[key].fail("only with mount: hand");
  for (const char* key : {"swing_fraction", "foot_lift_m", "foot_pitch_deg"})
    if (p.mount != Mount::kFoot && f[key].defined()) f[key].fail("only with mount: foot");
  p.step_length_m = param_in_range(f, "step_length_m", p.step_length_m, 0.1, 3);
  p.smoothing_s = param_in_range(f, "smoothing_s", p.smoothing_s, 0.05, 5);
  const double weinberg_range = std::pow(p.step_length_m + kWeinbergK2, 4);  // a_max - a_min
  p.vertical_amplitude_mps2 =
      param_in_range(f, "vertical_amplitude_mps2", weinberg_range / 2, 0, 100);
  p.forward_amplitude_mps2 =
      param_in_range(f, "forward_amplitude_mps2", p.forward_amplitude_mps2, 0, 100);
  p.lateral_amplitude_mps2 =
      param_in_range(f, "lateral_amplitude_mps2", p.lateral_amplitude_mps2, 0, 100);
  p.yaw_swing_deg = param_in_range(f, "yaw_swing_deg", p.yaw_swing_deg, 0, 180);
  p.yaw_swing_period_s = param_in_range(f, "yaw_swing_period_s", p.yaw_swing_period_s, 1, 1e5);
  p.swing_fraction = param_in_range(f, "swing_fraction", p.swing_fraction, 0.2, 0.8);
  p.foot_lift_m = param_in_range(f, "foot_lift_m", p.foot_lift_m, 0, 1);
  p.foot_pitch_deg = param_in_range(f, "foot_pitch_deg", p.foot_pitch_deg, 0, 90);
  p.yaw_offset_deg = param_in_range(f, "yaw_offset_deg", p.yaw_offset_deg, -180, 180);
  p.pitch_deg = param_in_range(f, "pitch_deg", p.pitch_deg, -90, 90);
  p.roll_deg = param_in_range(f, "roll_deg", p.roll_deg, -180, 180);
  p.accel_noise_mps2 = param_in_range(f, "accel_noise_mps2", p.accel_noise_mps2, 0, 10);
  p.accel_bias_mps2 = vec3_param(f, "accel_bias_mps2", 10);
  p.accel_bias_sigma_mps2 =
      param_in_range(f, "accel_bias_sigma_mps2", p.accel_bias_sigma_mps2, 0, 10);
  p.gyro_noise_rps = param_in_range(f, "gyro_noise_rps", p.gyro_noise_rps, 0, 10);
  p.gyro_bias_rps = vec3_param(f, "gyro_bias_rps", 10);
  p.gyro_bias_sigma_rps = param_in_range(f, "gyro_bias_sigma_rps", p.gyro_bias_sigma_rps, 0, 10);
  p.mag_field_ut = param_in_range(f, "mag_field_ut", p.mag_field_ut, 0, 1000);
  p.mag_inclination_deg = param_in_range(f, "mag_inclination_deg", p.mag_inclination_deg, -90, 90);
  p.mag_declination_deg =
      param_in_range(f, "mag_declination_deg", p.mag_declination_deg, -180, 180);
  p.mag_noise_ut = param_in_range(f, "mag_noise_ut", p.mag_noise_ut, 0, 100);
  p.mag_disturbance_ut = param_in_range(f, "mag_disturbance_ut", p.mag_disturbance_ut, 0, 1000);
  p.mag_disturbance_length_m =
      param_in_range(f, "mag_disturbance_length_m", p.mag_disturbance_length_m, 0.1, 1000);
  p.mag_anomalies = parse_anomalies(f["mag_anomalies"]);
  if (f["device_clock_offset_s"].defined())
    p.device_clock_offset_s = param_in_range(f, "device_clock_offset_s", 0, 0, 1e9);
  p.device_clock_drift_ppm =
      param_in_range(f, "device_clock_drift_ppm", p.device_clock_drift_ppm, -1000, 1000);

  auto field =
      std::make_shared<const MagneticField>(p, stream_rng(world.seed, "IMU magnetic-field"));
  SourceList out;
  for (const auto& w : world.walkers)
    out.push_back(
        std::make_unique<ImuSource>(p, field, w, stream_rng(world.seed, "IMU " + w.tag_id)));
  return out;
}

}  // namespace

SensorModel imu_sensor_model() { return {"imu", &make}; }

}  // namespace ips::sim
