#include "estimators/altitude/altitude_estimator.hpp"

#include <bit>
#include <cmath>
#include <cstdio>
#include <limits>
#include <tuple>

#include "core/barometric.hpp"
#include "core/repeat_filter.hpp"
#include "core/text_escape.hpp"
#include "estimators/altitude/models/baro_height.hpp"

namespace ips::altitude {

namespace {
// The barometers' range (003 Table 2.1: 26 to 126 kPa); anything else is a corrupt reading.
constexpr double kMinPressurePa = 30000.0;
constexpr double kMaxPressurePa = 125000.0;
constexpr size_t kMaxPending = 1000;  // per tag; more and the oldest are used at once
// The change detector (AltitudeEstimator::still_update): its window holds at least this many
// readings (a 1 s window of a 2 Hz sensor would hold two).
constexpr size_t kMinWindow = 5;

std::string seconds(double s) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f", s);
  return buf;
}
}  // namespace

AltitudeParams parse_altitude_params(const YamlField& s) {
  AltitudeParams p;
  if (!s.defined()) return p;
  if (!s.is_map()) s.fail("expected a map of altitude parameters");
  s.check_keys({"reference", "offsets_pa", "humidity_pct", "temperature_c", "gravity_mps2",
                "pressure_sigma_pa", "accel_sigma_mps2", "initial_speed_sigma_mps", "gate_sigma",
                "max_rejections", "align_wait_s", "max_reference_age_s",
                "reference_drift_pa_per_s", "max_gap_s", "publish_period_s", "floors",
                "max_tags", "sensors", "learn_noise", "mode", "relative_start_s",
                "still_window_s", "motion_window_s", "motion_sigma", "still_after_s",
                "wander_learn_s"});
  p.reference = s.get_string("reference", p.reference);
  const YamlField offsets = s["offsets_pa"];
  if (offsets.defined()) {
    if (!offsets.is_map()) offsets.fail("expected a map of sensor id: Pa");
    for (const auto& kv : offsets.node()) {
      if (!kv.first.IsScalar() || kv.first.Scalar().empty())
        offsets.fail("expected a map of sensor id: Pa");
      const std::string id = kv.first.Scalar();
      p.offsets_pa[id] = offsets.get_double_in(id, 0.0, -10000, 10000);
    }
  }
  p.humidity_pct = s.get_double_in("humidity_pct", p.humidity_pct, 0, 100);
  p.temperature_c = s.get_double_in("temperature_c", p.temperature_c, -60, 60);
  p.gravity_mps2 = s.get_double_in("gravity_mps2", p.gravity_mps2, 9.7, 9.9);
  p.pressure_sigma_pa = s.get_double_in("pressure_sigma_pa", p.pressure_sigma_pa, 1e-3, 1000);
  p.accel_sigma_mps2 = s.get_double_in("accel_sigma_mps2", p.accel_sigma_mps2, 1e-4, 100);
  p.initial_speed_sigma_mps =
      s.get_double_in("initial_speed_sigma_mps", p.initial_speed_sigma_mps, 1e-4, 100);
  p.gate_sigma = s.get_double_in("gate_sigma", p.gate_sigma, 1, 1e6);
  p.max_rejections =
      static_cast<int>(s.get_int_in("max_rejections", p.max_rejections, 1, 1000000));
  p.align_wait_s = s.get_double_in("align_wait_s", p.align_wait_s, 0, 60);
  p.max_reference_age_s =
      s.get_double_in("max_reference_age_s", p.max_reference_age_s, 0.01, 86400);
  p.reference_drift_pa_per_s =
      s.get_double_in("reference_drift_pa_per_s", p.reference_drift_pa_per_s, 0, 100);
  p.max_gap_s = s.get_double_in("max_gap_s", p.max_gap_s, 0.01, 3600);
  p.publish_period_s = s.get_double_in("publish_period_s", p.publish_period_s, 0, 3600);
  p.max_tags = static_cast<int>(s.get_int_in("max_tags", p.max_tags, 1, 100000));
  p.learn_noise = s.get_bool("learn_noise", p.learn_noise);
  p.mode = s.get_string("mode", p.mode);
  if (p.mode != "auto" && p.mode != "differential" && p.mode != "relative")
    s["mode"].fail("expected auto, differential or relative");
  p.relative_start_s = s.get_double_in("relative_start_s", p.relative_start_s, 0, 600);
  p.still_window_s = s.get_double_in("still_window_s", p.still_window_s, 0, 3600);
  p.motion_window_s = s.get_double_in("motion_window_s", p.motion_window_s, 0.1, 60);
  p.motion_sigma = s.get_double_in("motion_sigma", p.motion_sigma, 1, 100);
  p.still_after_s = s.get_double_in("still_after_s", p.still_after_s, 0, 600);
  p.wander_learn_s = s.get_double_in("wander_learn_s", p.wander_learn_s, 1, 86400);
  const YamlField sensors = s["sensors"];
  if (sensors.defined()) {
    if (!sensors.is_map()) sensors.fail("expected a map of sensor id: {type, pressure_sigma_pa}");
    for (const auto& kv : sensors.node()) {
      if (!kv.first.IsScalar() || kv.first.Scalar().empty())
        sensors.fail("expected a map of sensor id: {type, pressure_sigma_pa}");
      const std::string id = kv.first.Scalar();
      const YamlField f = sensors[id];
      if (!f.is_map()) f.fail("expected a map with type, oversampling, pressure_sigma_pa, rate_hz");
      f.check_keys({"type", "oversampling", "pressure_sigma_pa", "rate_hz"});
      SensorParams sp;
      sp.type = f.get_string("type", "");
      if (f["oversampling"].defined())
        sp.oversampling = static_cast<int>(f.get_int_in("oversampling", 0, 0, 3));
      if (!sp.type.empty() && std::isnan(sensor_type_sigma_pa(sp.type, sp.oversampling)))
        f["type"].fail("unknown barometer type '" + printable(sp.type) +
                       "' (known: BMP180, BMP280, BMP390, MPL115A1; or give pressure_sigma_pa)");
      if (sp.oversampling >= 0 && sp.type != "BMP180")
        f["oversampling"].fail("oversampling is read for a BMP180 only");
      if (f["pressure_sigma_pa"].defined())
        sp.pressure_sigma_pa = f.get_double_in("pressure_sigma_pa", 1.0, 1e-3, 1000);
      if (f["rate_hz"].defined()) sp.rate_hz = f.get_double_in("rate_hz", 1.0, 0.01, 1000);
      p.sensors[id] = sp;
    }
  }
  const YamlField floors = s["floors"];
  if (floors.defined()) {
    if (!floors.is_map()) floors.fail("expected a map with heights_m");
    floors.check_keys({"heights_m", "first_index", "carry_height_m", "dwell_s"});
    const YamlField heights = floors.required("heights_m");
    if (!heights.is_sequence() || heights.size() < 1 || heights.size() > 1000)
      heights.fail("expected a list of 1 to 1000 floor heights in m, ascending");
    for (size_t i = 0; i < heights.size(); ++i) {
      const double h = heights[i].as_double();
      if (!(std::abs(h) <= 10000)) heights[i].fail("must be in [-10000, 10000]");
      if (!p.floors.heights_m.empty() && !(h > p.floors.heights_m.back()))
        heights[i].fail("floor heights must be ascending");
      p.floors.heights_m.push_back(h);
    }
    p.floors.first_index =
        static_cast<int>(floors.get_int_in("first_index", p.floors.first_index, -1000, 1000));
    p.floors.carry_height_m =
        floors.get_double_in("carry_height_m", p.floors.carry_height_m, -10, 10);
    p.floors.dwell_s = floors.get_double_in("dwell_s", p.floors.dwell_s, 0, 3600);
  }
  return p;
}

double sensor_type_sigma_pa(const std::string& type, int oversampling) {
  // The data sheet's figure of the sensor's quietest setting unless the setting is given: the
  // learned noise never goes below the configured one (core/consistency.hpp) but rises to what
  // the sensor shows, up to 20x.
  // BMP180 data sheet (BST-BMP180-DS000, table of modes; BMP085's is the same): RMS noise 0.06,
  // 0.05, 0.04, 0.03 hPa at oss 0 to 3.
  if (type == "BMP180") return oversampling >= 0 && oversampling <= 3 ? 6.0 - oversampling : 3.0;
  // BMP280 data sheet (BST-BMP280-DS001, recommended settings): "indoor navigation", 1.6 cm
  // RMS, about 0.19 Pa ("weather monitoring", its noisiest: 26.4 cm, 3.1 Pa).
  if (type == "BMP280") return 0.19;
  // BMP390 data sheet (BST-BMP390-DS002): RMS noise 0.02 Pa in its highest-resolution setting.
  if (type == "BMP390") return 0.02;
  // MPL115A1 data sheet (NXP, rev. 8): resolution 0.15 kPa (accuracy +-1 kPa), no noise
  // figure: the resolution's quantisation noise, 150 / sqrt(12) = 43 Pa.
  if (type == "MPL115A1") return 43.0;
  return NAN;
}

double AltitudeParams::sigma_pa(const std::string& sensor_id) const {
  const auto it = sensors.find(sensor_id);
  if (it == sensors.end()) return pressure_sigma_pa;
  if (std::isfinite(it->second.pressure_sigma_pa)) return it->second.pressure_sigma_pa;
  const double s = sensor_type_sigma_pa(it->second.type, it->second.oversampling);
  return std::isfinite(s) ? s : pressure_sigma_pa;
}

std::string AltitudeParams::sigma_setting(const std::string& sensor_id) const {
  char v[32];
  std::snprintf(v, sizeof v, "%g", sigma_pa(sensor_id));
  const auto it = sensors.find(sensor_id);
  if (it == sensors.end()) return std::string("pressure_sigma_pa ") + v;
  if (std::isfinite(it->second.pressure_sigma_pa))
    return "sensors." + sensor_id + ".pressure_sigma_pa " + v;
  if (!it->second.type.empty())
    return "sensors." + sensor_id + ".type " + it->second.type + " (pressure_sigma_pa " + v + ")";
  return std::string("pressure_sigma_pa ") + v;
}

AltitudeEstimator::AltitudeEstimator(AltitudeSink sink, std::string source_name)
    : sink_(std::move(sink)), source_(std::move(source_name)) {}

void AltitudeEstimator::set_site(const Site& site) {
  AltitudeParams params = parse_altitude_params(site.estimator_params("altitude"));
  params_ = std::move(params);
  site_ = site;
  tracks_.clear();
  stations_.clear();
  consistency_.clear();
  consistency_.set_learning(params_.learn_noise);
  relative_ = params_.mode == "relative" ||
              (params_.mode == "auto" && site.baro_stations.empty() && params_.reference.empty());
}

utime_t AltitudeEstimator::reading_time(const std::string& sensor_id, utime_t stamp,
                                        uint64_t content) {
  auto found = timing_.find(sensor_id);
  if (found == timing_.end()) {
    if (timing_.size() >= 2 * static_cast<size_t>(params_.max_tags)) return stamp;
    found = timing_.try_emplace(sensor_id).first;
  }
  Timing& tm = found->second;
  if (tm.distinct == 0) {
    tm = {stamp, stamp, stamp, 1, content};
    return stamp;
  }
  if (stamp < tm.last_stamp) return 0;
  // Lines read at once share a stamp, but not all their values (a copy does).
  if (stamp == tm.last_stamp && content == tm.last_content) return kCopyOfPrevious;
  tm.last_content = content;
  // The sensor's period: configured, else its stamps' span over their count (a burst of N
  // lines read at once counts N readings), else 1 ms until a second of stamps is known.
  double period_s = 1e-3;
  const auto cfg = params_.sensors.find(sensor_id);
  if (cfg != params_.sensors.end() && std::isfinite(cfg->second.rate_hz)) {
    period_s = 1.0 / cfg->second.rate_hz;
  } else if (tm.last_stamp - tm.first_stamp >= s_to_utime(1.0)) {
    period_s = utime_to_s(tm.last_stamp - tm.first_stamp) / static_cast<double>(tm.distinct);
  }
  utime_t t = stamp;
  if (stamp == tm.last_stamp || stamp <= tm.last_time) {
    t = tm.last_time + std::max<utime_t>(1, s_to_utime(period_s));
    ++stats_.retimed;
  }
  ++tm.distinct;
  tm.last_stamp = stamp;
  tm.last_time = t;
  return t;
}

void AltitudeEstimator::on_baro(const baro_t& m) {
  ++stats_.readings_in;
  if (!site_) {
    ++stats_.dropped_no_site;
    return;
  }
  if (m.sensor_id.empty() || !plausible_utime(m.utime) ||
      !(m.pressure_pa >= kMinPressurePa && m.pressure_pa <= kMaxPressurePa) ||
      !(std::isnan(m.temperature_c) || std::abs(m.temperature_c) <= 100) ||
      !(std::isnan(m.humidity_pct) || (m.humidity_pct >= 0 && m.humidity_pct <= 100))) {
    ++stats_.dropped_invalid;
    return;
  }
  // A stamp far from the sensor's timeline waits for confirmation (core/time_guard.hpp).
  if (!guard_.admit(m.sensor_id, m.utime, [this, m] { on_baro(m); }, [] {})) {
    --stats_.readings_in;  // counted when handed over again, or dropped as a time jump
    return;
  }
  const uint64_t content =
      repeat_key(m.is_reference ? 1 : 0, std::bit_cast<int64_t>(m.temperature_c),
                 std::bit_cast<int64_t>(m.humidity_pct), m.pressure_pa);
  const utime_t t = reading_time(m.sensor_id, m.utime, content);
  if (t == kCopyOfPrevious) {
    ++stats_.dropped_duplicate;
    return;
  }
  if (t == 0) {
    ++stats_.dropped_out_of_order;
    return;
  }
  if (t != m.utime) {
    baro_t retimed = m;
    retimed.utime = t;
    return accept(retimed);
  }
  accept(m);
}

void AltitudeEstimator::accept(const baro_t& m) {
  const auto offset = params_.offsets_pa.find(m.sensor_id);
  const double pressure = m.pressure_pa - (offset == params_.offsets_pa.end() ? 0 : offset->second);
  if (m.utime > newest_utime_) newest_utime_ = m.utime;
  if (m.is_reference) {
    on_reference(m, pressure);
  } else {
    on_tag(m, pressure);
  }
  drain(false);
}

void AltitudeEstimator::on_reference(const baro_t& m, double pressure_pa) {
  ++stats_.reference_readings;
  double height = m.known_height_m;
  if (!std::isfinite(height)) {
    height = std::numeric_limits<double>::quiet_NaN();
    for (const auto& st : site_->baro_stations)
      if (st.id == m.sensor_id) height = st.position.z();
  }
  if (!std::isfinite(height) || std::abs(height) > 10000) {
    ++stats_.dropped_reference_without_height;
    problem_ = "reference " + printable(m.sensor_id) +
               " has no known height (none in its readings, no baro station of that id in "
               "the site): not used";
    return;
  }
  auto it = stations_.find(m.sensor_id);
  if (it == stations_.end()) {
    if (static_cast<int>(stations_.size()) >= params_.max_tags) {
      ++stats_.dropped_too_many_tags;
      return;
    }
    it = stations_.try_emplace(m.sensor_id, Station{ReferenceSeries(
                                                         2 * params_.max_reference_age_s)})
             .first;
  }
  if (!it->second.series.add({m.utime, pressure_pa, m.temperature_c, m.humidity_pct, height}))
    ++stats_.dropped_out_of_order;
}

void AltitudeEstimator::on_tag(const baro_t& m, double pressure_pa) {
  ++stats_.tag_readings;
  auto it = tracks_.find(m.sensor_id);
  if (it == tracks_.end()) {
    if (static_cast<int>(tracks_.size()) >= params_.max_tags) {
      ++stats_.dropped_too_many_tags;
      return;
    }
    it = tracks_.try_emplace(m.sensor_id).first;
  }
  Track& t = it->second;
  if (m.utime <= t.last_in_utime) {
    ++stats_.dropped_out_of_order;
    return;
  }
  t.last_in_utime = m.utime;
  t.pending.push_back({m.utime, pressure_pa, m.temperature_c});
}

const std::pair<const std::string, AltitudeEstimator::Station>*
AltitudeEstimator::pick_reference(utime_t t) const {
  const std::pair<const std::string, Station>* best = nullptr;
  double best_age = std::numeric_limits<double>::infinity();
  for (const auto& kv : stations_) {
    const auto at = kv.second.series.at(t);
    if (!at || at->age_s > params_.max_reference_age_s) continue;
    if (kv.first == params_.reference) return &kv;
    if (at->age_s < best_age) {
      best = &kv;
      best_age = at->age_s;
    }
  }
  return best;
}

void AltitudeEstimator::drain(bool flush) {
  const utime_t wait_us = s_to_utime(params_.align_wait_s);
  for (auto& [tag_id, t] : tracks_) {
    if (relative_ && !t.have_start && !t.pending.empty()) {
      // Height 0: the mean of the first relative_start_s of readings, once they are all here.
      const utime_t t0 = t.pending.front().utime;
      const utime_t end = t0 + s_to_utime(params_.relative_start_s);
      if (!flush && t.pending.back().utime < end && t.pending.size() <= kMaxPending) continue;
      double sum_p = 0, sum_t = 0;
      int n = 0, nt = 0;
      for (const TagReading& r : t.pending) {
        if (r.utime > end) break;
        sum_p += r.pressure_pa;
        ++n;
        if (std::isfinite(r.temperature_c)) {
          sum_t += r.temperature_c;
          ++nt;
        }
      }
      t.have_start = true;
      t.start_pressure_pa = sum_p / n;
      t.start_temperature_c = nt > 0 ? sum_t / nt : NAN;
      t.start_utime = t0;
    }
    while (!t.pending.empty()) {
      const TagReading r = t.pending.front();
      if (relative_) {
        t.pending.pop_front();
        use(tag_id, t, r, nullptr);
        continue;
      }
      const auto* station = pick_reference(r.utime);
      const bool covered = station && station->second.series.newest_utime() >= r.utime;
      if (!covered && !flush && newest_utime_ - r.utime < wait_us &&
          t.pending.size() <= kMaxPending)
        break;
      t.pending.pop_front();
      use(tag_id, t, r, station);
    }
  }
}

void AltitudeEstimator::finish() { drain(true); }

void AltitudeEstimator::use(const std::string& tag_id, Track& t, const TagReading& r,
                            const std::pair<const std::string, Station>* station) {
  BaroReference br;
  double temperature_c = NAN, humidity = params_.humidity_pct;
  double ref_var = 0;   // the reference reading's own noise, Pa^2 (white: in the measurement)
  double bias_var = 0;  // what the filter cannot average away, Pa^2: a held reference's drift
  double age_s = 0;
  if (relative_) {
    br.pressure_pa = t.start_pressure_pa;
    br.height_m = 0;
    temperature_c = std::isfinite(r.temperature_c) ? r.temperature_c : t.start_temperature_c;
    age_s = utime_to_s(r.utime - t.start_utime);
    // The start level is a mean of readings whose noise is not white over a second (real
    // sensors wander): its error is taken as one reading's, a bias held for the whole track.
    bias_var = params_.sigma_pa(tag_id) * params_.sigma_pa(tag_id);
  } else {
    if (!station) {
      if (stations_.empty()) {
        ++stats_.dropped_no_reference;
        problem_ = "no reference barometer heard yet: no altitude for " + printable(tag_id);
        return;
      }
      ++stats_.dropped_stale_reference;
      auto newest = stations_.begin();
      for (auto it = stations_.begin(); it != stations_.end(); ++it)
        if (it->second.series.newest_utime() > newest->second.series.newest_utime()) newest = it;
      const std::string& id = newest->first;
      const double age = utime_to_s(r.utime - newest->second.series.newest_utime());
      problem_ = "reference " + printable(id) + " stale: its newest reading is " + seconds(age) +
                 " s older than " + printable(tag_id) + "'s (max_reference_age_s " +
                 seconds(params_.max_reference_age_s) + ")";
      return;
    }
    if (t.reference_id != station->first) {
      if (!t.reference_id.empty()) ++stats_.reference_switches;
      t.reference_id = station->first;
    }
    const ReferenceAt ref = *station->second.series.at(r.utime);
    const ReferenceReading& rr = ref.reading;
    temperature_c = std::isfinite(rr.temperature_c) ? rr.temperature_c : r.temperature_c;
    if (std::isfinite(rr.humidity_pct)) humidity = rr.humidity_pct;
    br.pressure_pa = rr.pressure_pa;
    br.height_m = rr.height_m;
    age_s = ref.age_s;
    // A station listed under sensors has its own noise; else it is taken as exact (a
    // reference station is usually averaged or better than the tags).
    if (params_.sensors.count(station->first)) {
      const double s = params_.sigma_pa(station->first);
      ref_var = s * s;
    }
  }
  if (!std::isfinite(temperature_c)) temperature_c = params_.temperature_c;
  br.inverse_scale_height = barometric::inverse_scale_height_per_m(
      temperature_c, humidity, br.pressure_pa, params_.gravity_mps2);
  // Weather drift since the reference's level was read (a held station, or relative mode's
  // start): a bias common to all readings, reported in the height's sigma, not averaged away.
  const double drift = params_.reference_drift_pa_per_s * age_s;
  bias_var += drift * drift;
  const double sigma_cfg = params_.sigma_pa(tag_id);
  const double var_cfg = sigma_cfg * sigma_cfg + ref_var;
  // The noise in use: learned from this sensor's innovations (core/consistency.hpp) within
  // 1x to 20x the configured sigma, unless learn_noise is off.
  const double var = consistency_.variance("BARO", tag_id, var_cfg);

  CvFilter<1>& f = t.filter;
  const double dt_s = utime_to_s(r.utime - t.last_utime);
  bool restart = !t.initialised || dt_s > params_.max_gap_s;
  bool accepted = false;
  if (!restart) {
    f.predict(dt_s, params_.accel_sigma_mps2 * params_.accel_sigma_mps2);
    const BaroPrediction pred = predict_baro(f.x(0), br);
    const double hph = pred.dpressure_dheight * pred.dpressure_dheight * f.P(0, 0);
    const double innovation = r.pressure_pa - pred.pressure_pa;
    const UpdateResult u = update_baro_height<2>(f.x, f.P, 0, r.pressure_pa, br, var,
                                                 params_.gate_sigma * params_.gate_sigma);
    consistency_.add_scalar("BARO", tag_id, utime_to_s(r.utime), innovation, hph, var_cfg,
                            !u.accepted, params_.sigma_setting(tag_id));
    if (u.accepted) {
      ++stats_.used;
      t.rejections = 0;
      accepted = true;
    } else {
      ++stats_.rejected;
      restart = ++t.rejections >= params_.max_rejections;
    }
  }
  const double dpdh = br.inverse_scale_height * r.pressure_pa;
  if (restart) {
    if (t.initialised) ++stats_.restarts;
    ++stats_.used;
    f.x << br.height_m + barometric::height_above_m(br.pressure_pa, r.pressure_pa,
                                                     br.inverse_scale_height),
        0.0;
    f.P << var / (dpdh * dpdh), 0, 0,
        params_.initial_speed_sigma_mps * params_.initial_speed_sigma_mps;
    t.initialised = true;
    t.rejections = 0;
    restart_still(t, r.utime);
  } else if (accepted) {
    const double z = br.height_m + barometric::height_above_m(br.pressure_pa, r.pressure_pa,
                                                               br.inverse_scale_height);
    still_update(t, r.utime, dt_s, z, var / (dpdh * dpdh));
  }
  t.bias_var_m2 = bias_var / (dpdh * dpdh);
  t.last_utime = r.utime;
  t.floor.update(params_.floors, r.utime, t.moving ? f.x(0) : t.still_h);
  if (t.last_publish_utime == 0 ||
      r.utime - t.last_publish_utime >= s_to_utime(params_.publish_period_s))
    publish(tag_id, t, r.utime);
}

void AltitudeEstimator::restart_still(Track& t, utime_t utime) const {
  t.moving = params_.still_window_s <= 0;
  t.still_h = t.filter.x(0);
  t.still_var = std::max(0.0, t.filter.P(0, 0));
  t.mode_utime = utime;
  t.slow_since = 0;
  t.window.clear();
  t.window_sum = 0;
  t.moving_h.clear();
  t.mean_lean = 0;
}

void AltitudeEstimator::still_update(Track& t, utime_t utime, double dt_s, double z,
                                     double r_m2) {
  if (params_.still_window_s <= 0) return;  // the constant-velocity filter only
  // The still model: a height random walk whose Kalman gain settles at dt / still_window_s,
  // i.e. an average over about still_window_s of readings (q dt = r (dt / window)^2).
  const double a = dt_s / params_.still_window_s;
  t.still_var += r_m2 * a * a;
  const double innovation = z - t.still_h;
  const double gain = t.still_var / (t.still_var + r_m2);
  t.still_h += gain * innovation;
  t.still_var *= 1 - gain;
  // The change detector: the mean of the still model's innovations over motion_window_s against
  // the spread such means show while still (learned; never below white noise's r / n).
  t.window.emplace_back(utime, innovation);
  t.window_sum += innovation;
  const utime_t span = s_to_utime(params_.motion_window_s);
  while (t.window.size() > kMinWindow && t.window.front().first <= utime - span) {
    t.window_sum -= t.window.front().second;
    t.window.pop_front();
  }
  const double n = static_cast<double>(t.window.size());
  const double mean = t.window_sum / n;
  const double white = r_m2 / n + t.still_var;
  const double spread = std::isfinite(t.detect_var) ? std::max(t.detect_var, white) : white;
  const double since_s = utime_to_s(utime - t.mode_utime);
  // The moving filter's vertical speed beyond twice its own sigma.
  const bool speed_significant =
      std::abs(t.filter.x(1)) > 2 * std::sqrt(std::max(0.0, t.filter.P(1, 1)));
  if (t.moving) {
    // The still hypothesis, restarted on the moving filter whenever its innovations disagree
    // (a lower bar than for leaving still: staying moving a little longer costs little).
    if (t.window.size() >= 3 &&
        std::abs(mean) > 0.5 * params_.motion_sigma * std::sqrt(spread)) {
      auto moving_h = std::move(t.moving_h);
      restart_still(t, utime);
      t.moving = true;
      t.moving_h = std::move(moving_h);
    }
    // Slow: the moving filter's speed not significant, and its height over still_after_s
    // changed by less than twice what its noise and the wander explain.
    const double p00 = std::max(0.0, t.filter.P(0, 0));
    t.moving_h.emplace_back(utime, t.filter.x(0), p00);
    const utime_t back = s_to_utime(params_.still_after_s);
    while (t.moving_h.size() > 1 && std::get<0>(t.moving_h[1]) <= utime - back)
      t.moving_h.pop_front();
    const auto& [then_utime, then_h, then_p00] = t.moving_h.front();
    const bool slow =
        !speed_significant && utime - then_utime >= back &&
        std::abs(t.filter.x(0) - then_h) <= 2 * std::sqrt(p00 + then_p00);
    if (!slow) {
      t.slow_since = 0;
    } else if (t.slow_since == 0) {
      t.slow_since = utime;
    }
    // (not since_s: a restart of the still hypothesis above moved mode_utime)
    if (utime_to_s(utime - t.mode_utime) >= params_.still_after_s && t.slow_since != 0 &&
        utime_to_s(utime - t.slow_since) >= params_.still_after_s) {
      // The still model starts from the moving filter's mean height over still_after_s (its
      // latest height alone carries its noise into the long average).
      double sum = 0;
      for (const auto& e : t.moving_h) sum += std::get<1>(e);
      t.still_h = sum / static_cast<double>(t.moving_h.size());
      t.still_var = p00;
      t.moving = false;
      t.mode_utime = utime;
    }
    return;
  }
  if (since_s < params_.motion_window_s) return;  // a full window since the switch
  if (std::abs(mean) > params_.motion_sigma * std::sqrt(spread)) {
    ++stats_.motion_starts;
    t.moved = true;
    restart_still(t, utime);
    t.moving = true;
    return;
  }
  // Relative mode: while the tag has not moved since its start, the long average's distance
  // from height 0 is the start level's own error (e.g. a sensor still warming up in its first
  // second); the largest seen stays in the published sigma.
  if (relative_ && !t.moved && since_s >= params_.still_window_s / 4)
    t.start_error_m2 = std::max(t.start_error_m2, t.still_h * t.still_h);
  // Learned while still; one squared mean counts at most 4x the current spread (a variance), so
  // a slow real change (stairs at 0.1 m/s) is not learned as noise before it is detected. The
  // detector's spread rises over
  // wander_learn_s and falls ten times slower (the means are correlated over the wander's own
  // time scale, tens of seconds: a quick fall would forget it between two excursions); the
  // sigma's, an even average over 2 wander_learn_s.
  // Not while the means lean one way (their average over wander_learn_s beyond half the
  // spread: a slow ramp, which the detector is about to see) or the moving filter's speed is
  // significant.
  const double lean_w = std::min(1.0, dt_s / params_.wander_learn_s);
  t.mean_lean += lean_w * (mean - t.mean_lean);
  if (std::abs(t.mean_lean) > 0.5 * std::sqrt(spread) || speed_significant) return;
  const double m2 = std::min(mean * mean, 4 * spread);
  if (!std::isfinite(t.mean_var)) t.mean_var = t.detect_var = white;
  const double w = std::min(1.0, dt_s / (2 * params_.wander_learn_s));
  t.mean_var += w * (m2 - t.mean_var);
  const double learn_s = params_.wander_learn_s * (m2 > t.detect_var ? 1 : 10);
  t.detect_var += std::min(1.0, dt_s / learn_s) * (m2 - t.detect_var);
  // The wander: what the means show beyond a window of white noise (r / n readings).
  t.wander_var = std::max(0.0, t.mean_var - r_m2 / n);
}

void AltitudeEstimator::publish(const std::string& tag_id, Track& t, utime_t utime) {
  altitude_t a;
  a.utime = utime;
  a.source = source_;
  a.relative = relative_;
  a.tag_id = tag_id;
  const bool still = !t.moving;
  a.height_m = still ? t.still_h : t.filter.x(0);
  // The filter's own variance, the reference's bias (drift; relative mode: the start level's
  // error) and the sensor's slow wander, which the filters cannot average away (relative mode:
  // twice, the start level carries it too).
  const double own = still ? t.still_var : std::max(0.0, t.filter.P(0, 0));
  a.height_std_m =
      std::sqrt(own + t.bias_var_m2 + (relative_ ? 2 : 1) * t.wander_var + t.start_error_m2);
  a.vertical_speed_mps = still ? 0.0 : t.filter.x(1);
  a.floor_valid = t.floor.valid();
  a.floor = a.floor_valid ? t.floor.floor(params_.floors) : 0;
  t.last_publish_utime = utime;
  ++stats_.altitudes_out;
  sink_(a);
}

}  // namespace ips::altitude
