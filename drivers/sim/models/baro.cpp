// Barometers (BARO): one on every walker (sensor_id = tag id) and one per site baro station
// (is_reference, known_height_m = the station's z). Source: ../shared/reference/003_baro.md
// (Marek 2024, two BMP280 read at 10 Hz, one on an anchor at 2.4 m and one on the tag).
//
// True pressure: the hypsometric equation with virtual temperature, for an isothermal layer
// (indoors, a few metres):
//   p(z, t) = (p_origin + w(t)) * exp(-g * z / (R_d * T_v)),
//   T_v = T / (1 - (e / p_origin) * (1 - M_v / M_d)),  e = phi * 611.2 exp(17.67 Tc / (Tc + 243.5))
// which is the reference's (2.1) with its moist-air density (2.3)-(2.9), because
// p / rho = R * T / M_eff = R_d * T_v. (2.9) writes Tetens' denominator in kelvin, T - 29.65, which
// is Tc + 243.5; the sensors' absolute accuracy is 100 Pa (Table 2.1), not the "100 hPa" of its
// section 5.1. At 293 K, 40 %, 101325 Pa and g = 9.81 this gives rho = 1.2006 kg/m^3 and
// dp/dz = -11.78 Pa/m (reproduction target 1).
//
// Reading: p(z, t) + a constant per-sensor offset (tens of Pa; the reference calibrated about
// 25 Pa) + Gaussian noise (0.2 Pa RMS, BMP280, Table 2.1), rounded to the resolution (0.016 Pa).
// w(t), the weather, is common to every sensor: a linear trend plus a random walk sampled every
// 10 s and interpolated linearly, so it cancels in the difference of two sensors (the point of
// differential barometry). Temperature: the air's plus a per-sensor offset and noise. Humidity:
// NaN unless humidity_reported.
#include <algorithm>
#include <cmath>
#include <ips/baro_t.hpp>
#include <memory>

#include "core/barometric.hpp"
#include "drivers/sim/sensor_model.hpp"

namespace ips::sim {

namespace {

struct BaroParams {
  double rate_hz = 10.0;                 // the reference's BMP280 read rate
  double origin_pressure_pa = 101325.0;  // true pressure at the site origin (z = 0), no weather
  double temperature_c = 20.0;           // air (the reference's sensitivity default is 293 K)
  double humidity_pct = 40.0;            // air, for the virtual temperature (reference: 40 %)
  double gravity_mps2 = 9.81;            // the reference's constant g
  double noise_sigma_pa = 0.2;           // BMP280 RMS noise, Table 2.1
  double resolution_pa = 0.016;          // BMP280 resolution, Table 2.1; 0: no rounding
  double offset_sigma_pa = 25.0;         // per-sensor constant offset (reference: ~25 Pa found)
  double weather_walk_pa_10min = 3.0;    // sigma of the weather's change over 10 min (random walk)
  double weather_trend_pa_per_h = 0.0;   // linear weather trend
  double temperature_noise_sigma_c = 0.05;  // per reading
  double temperature_offset_sigma_c = 0.5;  // per sensor (BMP280 datasheet: +-0.5 C at 25 C)
  bool humidity_reported = false;
  double humidity_noise_sigma_pct = 1.0;
  // Thermal settling after power-on (003 section 2.4 discarded its first 3 min): a per-sensor
  // offset drawn N(0, warmup_sigma_pa) that decays as exp(-t / warmup_tau_s).
  double warmup_sigma_pa = 0.0;
  double warmup_tau_s = 60.0;
  bool on_tags = true;
  bool on_stations = true;
};

// The weather's pressure change common to every sensor: trend * t plus a Gaussian random walk
// sampled every kStepS and interpolated linearly. It is a function of time alone, drawn from its
// own stream and grown on demand in order, so every sensor sees the same value whatever the
// order of queries. It keeps the whole walk: 8 bytes per 10 s of scenario.
class WeatherDrift {
 public:
  WeatherDrift(double walk_pa_10min, double trend_pa_per_h, std::mt19937_64 rng)
      : step_sigma_pa_(walk_pa_10min * std::sqrt(kStepS / 600.0)),
        trend_pa_per_s_(trend_pa_per_h / 3600.0),
        rng_(std::move(rng)) {}

  double at(double t_s) {
    t_s = std::max(0.0, t_s);
    if (step_sigma_pa_ == 0) return trend_pa_per_s_ * t_s;
    const double cell = std::floor(t_s / kStepS);
    const auto k = static_cast<size_t>(cell);
    std::normal_distribution<double> gauss(0.0, 1.0);
    while (walk_.size() < k + 2) walk_.push_back(walk_.back() + step_sigma_pa_ * gauss(rng_));
    const double f = t_s / kStepS - cell;
    return trend_pa_per_s_ * t_s + walk_[k] + f * (walk_[k + 1] - walk_[k]);
  }

 private:
  static constexpr double kStepS = 10.0;
  double step_sigma_pa_;
  double trend_pa_per_s_;
  std::mt19937_64 rng_;
  std::vector<double> walk_{0.0};
};

// The air column: what the hypsometric equation needs, computed once.
struct Atmosphere {
  double origin_pressure_pa;
  double inverse_scale_height_per_m;  // g / (R_d * T_v)

  static Atmosphere make(const BaroParams& p) {
    return {p.origin_pressure_pa,
            barometric::inverse_scale_height_per_m(p.temperature_c, p.humidity_pct,
                                                   p.origin_pressure_pa, p.gravity_mps2)};
  }
  double pressure_pa(double z_m, double weather_pa) const {
    return barometric::pressure_above_pa(origin_pressure_pa + weather_pa, z_m,
                                         inverse_scale_height_per_m);
  }
};

// One barometer: on a walker (walker != nullptr) or fixed at a station.
struct BaroSensor {
  std::string id;
  const TagTrajectory* walker = nullptr;
  double fixed_z_m = 0.0;
  bool is_reference = false;
  std::string stream;  // its random stream's name
};

class BaroSource : public PeriodicSource {
 public:
  BaroSource(const BaroParams& p, const Atmosphere& air, std::shared_ptr<WeatherDrift> weather,
             BaroSensor sensor, double given_offset_pa, int64_t phase_us, std::mt19937_64 rng,
             double warmup_pa)
      : PeriodicSource(period_us(p.rate_hz), phase_us),
        p_(p),
        air_(air),
        weather_(std::move(weather)),
        sensor_(std::move(sensor)),
        rng_(std::move(rng)),
        warmup_pa_(warmup_pa) {
    // The sensor's constants are the first draws of its stream, drawn whether or not the offset
    // is given, so that giving one does not change the noise.
    std::normal_distribution<double> gauss(0.0, 1.0);
    const double offset_draw = gauss(rng_);
    const double temperature_offset_draw = gauss(rng_);
    offset_pa_ = std::isnan(given_offset_pa) ? p_.offset_sigma_pa * offset_draw : given_offset_pa;
    temperature_offset_c_ = p_.temperature_offset_sigma_c * temperature_offset_draw;
  }

 protected:
  bool emit(utime_t t, double t_s, SimEvent& ev) override {
    std::normal_distribution<double> gauss(0.0, 1.0);
    const double pressure_noise = gauss(rng_);
    const double temperature_noise = gauss(rng_);
    const double humidity_noise = gauss(rng_);
    const double z = sensor_.walker ? sensor_.walker->path.at(t_s).position.z() : sensor_.fixed_z_m;
    double pressure =
        air_.pressure_pa(z, weather_->at(t_s)) + offset_pa_ + p_.noise_sigma_pa * pressure_noise;
    if (warmup_pa_ != 0) pressure += warmup_pa_ * std::exp(-t_s / p_.warmup_tau_s);
    if (p_.resolution_pa > 0) pressure = std::round(pressure / p_.resolution_pa) * p_.resolution_pa;
    baro_t m;
    m.utime = t;
    m.source = kSimSource;
    m.sensor_id = sensor_.id;
    m.pressure_pa = pressure;
    m.temperature_c =
        p_.temperature_c + temperature_offset_c_ + p_.temperature_noise_sigma_c * temperature_noise;
    m.humidity_pct =
        p_.humidity_reported
            ? std::clamp(p_.humidity_pct + p_.humidity_noise_sigma_pct * humidity_noise, 0.0, 100.0)
            : std::numeric_limits<double>::quiet_NaN();
    m.is_reference = sensor_.is_reference;
    m.known_height_m =
        sensor_.is_reference ? sensor_.fixed_z_m : std::numeric_limits<double>::quiet_NaN();
    encode_event(m, t, "BARO", ev);
    return true;
  }

 private:
  BaroParams p_;
  Atmosphere air_;
  std::shared_ptr<WeatherDrift> weather_;
  BaroSensor sensor_;
  std::mt19937_64 rng_;
  double warmup_pa_ = 0.0;
  double offset_pa_ = 0.0;
  double temperature_offset_c_ = 0.0;
};

SourceList make(const YamlField& f, const SimWorld& world) {
  f.check_keys({"enabled", "rate_hz", "origin_pressure_pa", "temperature_c", "humidity_pct",
                "gravity_mps2", "noise_sigma_pa", "resolution_pa", "offset_sigma_pa", "offsets_pa",
                "weather_walk_pa_10min", "weather_trend_pa_per_h", "temperature_noise_sigma_c",
                "temperature_offset_sigma_c", "humidity_reported", "humidity_noise_sigma_pct",
                "warmup_sigma_pa", "warmup_tau_s", "on_tags", "on_stations"});
  BaroParams p;
  p.rate_hz = param_in_range(f, "rate_hz", p.rate_hz, 0.01, 1000);
  // The sensors' range (Table 2.1: 30 to 125 kPa).
  p.origin_pressure_pa =
      param_in_range(f, "origin_pressure_pa", p.origin_pressure_pa, 30000, 125000);
  p.temperature_c = param_in_range(f, "temperature_c", p.temperature_c, -40, 60);
  p.humidity_pct = param_in_range(f, "humidity_pct", p.humidity_pct, 0, 100);
  p.gravity_mps2 = param_in_range(f, "gravity_mps2", p.gravity_mps2, 9.7, 9.9);
  p.noise_sigma_pa = param_in_range(f, "noise_sigma_pa", p.noise_sigma_pa, 0, 1000);
  p.resolution_pa = param_in_range(f, "resolution_pa", p.resolution_pa, 0, 100);
  p.offset_sigma_pa = param_in_range(f, "offset_sigma_pa", p.offset_sigma_pa, 0, 10000);
  p.weather_walk_pa_10min =
      param_in_range(f, "weather_walk_pa_10min", p.weather_walk_pa_10min, 0, 1000);
  p.weather_trend_pa_per_h =
      param_in_range(f, "weather_trend_pa_per_h", p.weather_trend_pa_per_h, -1000, 1000);
  p.temperature_noise_sigma_c =
      param_in_range(f, "temperature_noise_sigma_c", p.temperature_noise_sigma_c, 0, 10);
  p.temperature_offset_sigma_c =
      param_in_range(f, "temperature_offset_sigma_c", p.temperature_offset_sigma_c, 0, 10);
  p.humidity_reported = f.get_bool("humidity_reported", p.humidity_reported);
  p.humidity_noise_sigma_pct =
      param_in_range(f, "humidity_noise_sigma_pct", p.humidity_noise_sigma_pct, 0, 50);
  p.warmup_sigma_pa = param_in_range(f, "warmup_sigma_pa", p.warmup_sigma_pa, 0, 1000);
  p.warmup_tau_s = param_in_range(f, "warmup_tau_s", p.warmup_tau_s, 1, 3600);
  p.on_tags = f.get_bool("on_tags", p.on_tags);
  p.on_stations = f.get_bool("on_stations", p.on_stations);

  std::vector<BaroSensor> sensors;
  if (p.on_tags)
    for (const auto& w : world.walkers)
      sensors.push_back({w.tag_id, &w, 0.0, false, "BARO " + w.tag_id});
  if (p.on_stations)
    for (const auto& s : world.site.baro_stations) {
      for (const auto& w : world.walkers)
        if (w.tag_id == s.id)
          f.fail("baro station '" + s.id + "' has the id of a tag: BARO sensor ids must be unique");
      // "station" in the stream name: a station's noise never equals a same-named tag's.
      sensors.push_back({s.id, nullptr, s.position.z(), true, "BARO station " + s.id});
    }

  // Offsets given per sensor id override the drawn ones.
  std::vector<double> given(sensors.size(), std::numeric_limits<double>::quiet_NaN());
  const YamlField offsets = f["offsets_pa"];
  if (offsets.defined() && !offsets.is_map()) offsets.fail("expected a map of sensor id: Pa");
  if (offsets.is_map()) {
    for (const auto& kv : offsets.node()) {
      const std::string id = kv.first.IsScalar() ? kv.first.Scalar() : "?";
      const auto it = std::find_if(sensors.begin(), sensors.end(),
                                   [&](const BaroSensor& s) { return s.id == id; });
      if (it == sensors.end()) {
        std::string ids;
        for (const auto& s : sensors) ids += (ids.empty() ? "" : ", ") + s.id;
        YamlField(kv.first, f.origin(), offsets.path() + "." + id)
            .fail("no barometer has this id (barometers: " + ids + ")");
      }
      given[static_cast<size_t>(it - sensors.begin())] =
          param_in_range(offsets, id.c_str(), 0.0, -10000, 10000);
    }
  }

  const Atmosphere air = Atmosphere::make(p);
  auto weather = std::make_shared<WeatherDrift>(p.weather_walk_pa_10min, p.weather_trend_pa_per_h,
                                                stream_rng(world.seed, "BARO weather"));
  const int64_t period = period_us(p.rate_hz);
  const auto n = static_cast<int64_t>(std::max<size_t>(1, sensors.size()));
  SourceList out;
  for (size_t i = 0; i < sensors.size(); ++i) {
    // Sensors spread over the period, as unsynchronised devices are.
    const int64_t phase = (static_cast<int64_t>(i) * period) / n + 3000;
    std::mt19937_64 rng = stream_rng(world.seed, sensors[i].stream);
    // Its own stream, so that a warm-up changes no other value.
    std::mt19937_64 warmup_rng = stream_rng(world.seed, sensors[i].stream + " warmup");
    const double warmup_pa = p.warmup_sigma_pa * std::normal_distribution<double>(0, 1)(warmup_rng);
    out.push_back(std::make_unique<BaroSource>(p, air, weather, sensors[i], given[i], phase,
                                               std::move(rng), warmup_pa));
  }
  return out;
}

}  // namespace

SensorModel baro_sensor_model() { return {"baro", &make}; }

}  // namespace ips::sim
