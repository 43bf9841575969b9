#include "estimators/uwb_twr/twr_estimator.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "core/multilateration.hpp"
#include "core/track_limit.hpp"

namespace ips::uwb_twr {

TwrParams parse_twr_params(const YamlField& s) {
  TwrParams p;
  if (!s.defined()) return p;
  if (!s.is_map()) s.fail("expected a map of uwb_twr parameters");
  s.check_keys({"mode", "init_solver", "range_sigma_m", "accel_psd", "gate_sigma", "nlos_gate_sigma",
                "nlos_downweight_sigma",
                "epoch_window_s", "init_velocity_sigma_mps", "reinit_after_rejections",
                "max_coast_s", "publish_period_s", "reorder_tolerance_s", "max_range_m",
                "max_tags", "learn_noise", "nlos_power_db", "nlos_power_los_db", "nlos_power_var_scale",
                "range_bias_m", "range_bias_per_m", "range_offsets_m", "range_scales", "learn_bias",
                "bias_prior_sigma_m", "bias_pair_sigma_m", "bias_window", "bias_max_m",
                "epoch_fixes"});
  // Every parameter is bounded, not just positive: a SITE message on the bus is outside input.
  auto positive = [&](const char* key, double& v) {
    v = s.get_double(key, v);
    if (!(v > 0 && v <= 1e6)) s[key].fail("must be in (0, 1e6]");
  };
  std::string mode = s.get_string("mode", "auto");
  if (mode != "auto" && mode != "3d") s["mode"].fail("expected auto (2D when the tag height is known) or 3d");
  p.force_3d = mode == "3d";
  const std::string solver = s.get_string("init_solver", "lm");
  const auto parsed = parse_multilateration_solver(solver);
  if (!parsed) s["init_solver"].fail("expected lm, gauss_newton or foy");
  p.init_solver = *parsed;
  positive("range_sigma_m", p.range_sigma_m);
  positive("accel_psd", p.accel_psd);
  positive("gate_sigma", p.gate_sigma);
  positive("nlos_gate_sigma", p.nlos_gate_sigma);
  positive("nlos_downweight_sigma", p.nlos_downweight_sigma);
  positive("epoch_window_s", p.epoch_window_s);
  positive("init_velocity_sigma_mps", p.init_velocity_sigma_mps);
  positive("max_coast_s", p.max_coast_s);
  positive("publish_period_s", p.publish_period_s);
  positive("reorder_tolerance_s", p.reorder_tolerance_s);
  positive("max_range_m", p.max_range_m);
  p.reinit_after_rejections =
      static_cast<int>(s.get_int("reinit_after_rejections", p.reinit_after_rejections));
  if (p.reinit_after_rejections < 1 || p.reinit_after_rejections > 1000000)
    s["reinit_after_rejections"].fail("must be in [1, 1000000]");
  p.learn_noise = s.get_bool("learn_noise", p.learn_noise);
  p.nlos_power_db = s.get_double_in("nlos_power_db", p.nlos_power_db, 0, 100);
  p.nlos_power_los_db = s.get_double_in("nlos_power_los_db", p.nlos_power_los_db, 0, 100);
  if (p.nlos_power_db > 0 && p.nlos_power_los_db >= p.nlos_power_db)
    s["nlos_power_los_db"].fail("must be below nlos_power_db");
  p.nlos_power_var_scale =
      s.get_double_in("nlos_power_var_scale", p.nlos_power_var_scale, 1, 1e6);
  p.range_bias_m = s.get_double_in("range_bias_m", p.range_bias_m, -10, 10);
  p.range_bias_per_m = s.get_double_in("range_bias_per_m", p.range_bias_per_m, -0.1, 0.1);
  // A map of anchor id (or tag/anchor) to a value in [lo, hi].
  const auto pair_map = [&s](const char* key, const char* what, double lo, double hi) {
    std::map<std::string, double> out;
    const YamlField field = s[key];
    if (!field.defined()) return out;
    const std::string expected = std::string("expected a map of anchor id (or tag/anchor): ") + what;
    if (!field.is_map()) field.fail(expected);
    for (const auto& kv : field.node()) {
      if (!kv.first.IsScalar() || kv.first.Scalar().empty()) field.fail(expected);
      const std::string k = kv.first.Scalar();
      out[k] = field.get_double_in(k, 0.0, lo, hi);
    }
    return out;
  };
  p.range_offsets_m = pair_map("range_offsets_m", "offset in m", -10, 10);
  p.range_scales = pair_map("range_scales", "scale factor", -0.1, 0.1);
  p.learn_bias = s.get_bool("learn_bias", p.learn_bias);
  p.bias_prior_sigma_m = s.get_double_in("bias_prior_sigma_m", p.bias_prior_sigma_m, 0.001, 10);
  p.bias_pair_sigma_m = s.get_double_in("bias_pair_sigma_m", p.bias_pair_sigma_m, 0.001, 10);
  p.bias_window = static_cast<int>(s.get_int_in("bias_window", p.bias_window, 1, 1000000));
  p.bias_max_m = s.get_double_in("bias_max_m", p.bias_max_m, 0, 10);
  p.epoch_fixes = s.get_bool("epoch_fixes", p.epoch_fixes);
  p.max_tags = static_cast<int>(s.get_int("max_tags", p.max_tags));
  if (p.max_tags < 1 || p.max_tags > 100000) s["max_tags"].fail("must be in [1, 100000]");
  return p;
}

double pair_setting(const std::map<std::string, double>& values, const std::string& tag_id,
                    const std::string& anchor_id) {
  if (auto it = values.find(tag_id + "/" + anchor_id); it != values.end()) return it->second;
  if (auto it = values.find(anchor_id); it != values.end()) return it->second;
  return std::numeric_limits<double>::quiet_NaN();
}

PairOffsets initial_offsets(const TwrParams& p, const std::string& tag_id,
                            const std::vector<Anchor>& anchors) {
  std::vector<double> prior(anchors.size()), prior_sigma(anchors.size());
  std::vector<bool> common(anchors.size());
  for (size_t k = 0; k < anchors.size(); ++k) {
    const double offset = pair_setting(p.range_offsets_m, tag_id, anchors[k].id);
    prior[k] = std::isnan(offset) ? 0.0 : offset;
    // A configured offset is known to a few cm (a calibration); otherwise a common part
    // (bias_prior_sigma_m) and the pair's own (bias_pair_sigma_m). Not learned: taken as known
    // (0 unless configured).
    common[k] = std::isnan(offset);
    prior_sigma[k] = !p.learn_bias         ? 0.0
                     : std::isnan(offset) ? p.bias_pair_sigma_m
                                          : std::min(p.bias_pair_sigma_m, 0.05);
  }
  PairOffsets offsets;
  offsets.reset(prior, prior_sigma, common, p.bias_prior_sigma_m);
  if (!p.range_scales.empty()) {
    std::vector<double> scales(anchors.size());
    for (size_t k = 0; k < anchors.size(); ++k) {
      const double s = pair_setting(p.range_scales, tag_id, anchors[k].id);
      scales[k] = std::isnan(s) ? 0.0 : s;
    }
    offsets.set_scales(std::move(scales));
  }
  return offsets;
}

TwrEstimator::TwrEstimator(PoseSink sink, std::string source_name)
    : sink_(std::move(sink)), source_(std::move(source_name)) {}

void TwrEstimator::set_site(const Site& site) {
  params_ = parse_twr_params(site.estimator_params("uwb_twr"));
  ConsistencyOptions co;
  co.learn = params_.learn_noise;
  consistency_ = ConsistencyMonitor(co);
  range_setting_ = setting_text("range_sigma_m", params_.range_sigma_m);
  site_ = site;
  tracks_.clear();
  enabled_uwb_anchors_ = 0;
  for (const auto& a : site.anchors) enabled_uwb_anchors_ += a.enabled && a.kind == "uwb";
}

void TwrEstimator::on_range(const uwb_range_t& m) {
  ++stats_.ranges_in;
  if (!site_) {
    ++stats_.dropped_no_site;
    return;
  }
  if (!plausible_utime(m.utime) || !std::isfinite(m.range_m) || m.range_m < 0 ||
      m.range_m > params_.max_range_m) {
    ++stats_.dropped_invalid;
    return;
  }
  if (site_->find_anchor(m.tag_id)) {
    // Anchor-to-anchor ranging (ips-uwb-survey's input): neither end is a tag.
    ++stats_.anchor_pair_ranges;
    return;
  }
  const Anchor* anchor = site_->find_anchor(m.anchor_id);
  if (!anchor || !anchor->enabled || anchor->kind != "uwb") {
    ++(enabled_uwb_anchors_ == 0 ? stats_.dropped_no_anchors : stats_.dropped_unknown_anchor);
    return;
  }
  if (m.tag_id.empty()) {
    ++stats_.dropped_invalid;
    return;
  }
  // A stamp far from the tag's timeline waits for confirmation (core/time_guard.hpp); a tag whose
  // clock went back starts afresh.
  if (!guard_.admit(m.tag_id, m.utime, [this, m] { on_range(m); },
                    [this, &m] { tracks_.erase(m.tag_id); })) {
    --stats_.ranges_in;  // counted when handed over again, or dropped as a time jump
    return;
  }
  auto it = tracks_.find(m.tag_id);
  const bool inserted = it == tracks_.end();
  if (inserted) {
    // A track silent for 10 coast periods makes room (core/track_limit.hpp).
    if (!room_for_track(tracks_, m.utime, params_.max_tags,
                        10 * s_to_utime(params_.max_coast_s))) {
      ++stats_.dropped_too_many_tags;
      return;
    }
    it = tracks_.try_emplace(m.tag_id).first;
  }
  Track& t = it->second;
  if (inserted) {
    const Tag* tag = site_->find_tag(m.tag_id);
    t.planar = !params_.force_3d && tag && std::isfinite(tag->height_m);
    t.height_m = t.planar ? tag->height_m : 0.0;
    t.anchor_rejections.assign(site_->anchors.size(), 0);
    t.anchor_heard_utime.assign(site_->anchors.size(), 0);
    t.tag_id = m.tag_id;
    t.bias = initial_offsets(params_, m.tag_id, site_->anchors);
  }
  const auto anchor_index = static_cast<size_t>(anchor - site_->anchors.data());
  // A copy of a range already taken (a LAN's repeated datagram) would be fused twice.
  if (t.repeats.repeated(
          repeat_key(m.utime, m.seq, static_cast<int64_t>(anchor_index), m.range_m))) {
    ++stats_.dropped_duplicate;
    return;
  }
  if (t.newest_utime != 0) {
    const utime_t behind = t.newest_utime - m.utime;
    if (behind > s_to_utime(params_.max_coast_s)) {
      // Time went back further than any reordering explains (a clock step, a replay restarted,
      // or one bogus future stamp before): start this track afresh rather than drop forever.
      ++stats_.time_resets;
      Track fresh;
      fresh.anchor_rejections.assign(t.anchor_rejections.size(), 0);
      fresh.anchor_heard_utime.assign(t.anchor_heard_utime.size(), 0);
      fresh.tag_id = t.tag_id;
      fresh.bias = t.bias;  // the radios' offsets outlive a restarted track
      fresh.cycle_s = t.cycle_s;
      fresh.planar = t.planar;
      fresh.height_m = t.height_m;
      fresh.repeats = t.repeats;
      fresh.noise_links = t.noise_links;
      t = std::move(fresh);
    } else if (behind > s_to_utime(params_.reorder_tolerance_s)) {
      ++stats_.dropped_late;
      return;
    }
  }
  if (t.first_utime == 0) t.first_utime = m.utime;
  t.newest_utime = std::max(t.newest_utime, m.utime);
  // The round of the anchors: how long until an anchor is heard again (a slow running mean;
  // gaps beyond max_coast_s are outages, not the round).
  const utime_t heard = t.anchor_heard_utime[anchor_index];
  if (heard != 0 && m.utime > heard && m.utime - heard <= s_to_utime(params_.max_coast_s)) {
    const double gap_s = utime_to_s(m.utime - heard);
    t.cycle_s = t.cycle_s == 0 ? gap_s : t.cycle_s + 0.05 * (gap_s - t.cycle_s);
  }
  t.anchor_heard_utime[anchor_index] = std::max(heard, m.utime);
  const double range_m = t.bias.unscaled(
      anchor_index, corrected_range(m.range_m, params_.range_bias_m, params_.range_bias_per_m));
  t.recent.push_back({m.utime, anchor_index, range_m});
  while (t.recent.size() > 64 ||
         (t.recent.size() > 1 && m.utime - t.recent.front().utime > epoch_window(t)))
    t.recent.pop_front();
  if (epoch_sink_ && params_.epoch_fixes) publish_epoch_fix(t, m.tag_id, m.utime);
  if (params_.learn_bias) learn_offsets(t, m.utime);

  if (t.initialised && m.utime - t.last_accept_utime > s_to_utime(params_.max_coast_s))
    t.initialised = false;
  if (!t.initialised) {
    if (!try_initialise(t, m.utime)) ++stats_.ranges_initialising;
    return;
  }
  if (t.planar) {
    update<2>(t, t.f2, anchor_index, m);
  } else {
    update<3>(t, t.f3, anchor_index, m);
  }
  if (t.check_fix) {
    t.check_fix = false;
    if (t.initialised && try_initialise(t, m.utime, true)) ++stats_.reacquisitions;
  }
  if (!t.initialised) return;
  if (t.planar) {
    publish<2>(t, t.f2, m.tag_id, m.utime);
  } else {
    publish<3>(t, t.f3, m.tag_id, m.utime);
  }
}

template <int D>
void TwrEstimator::update(Track& t, CvFilter<D>& f, size_t anchor_index, const uwb_range_t& m) {
  if (m.utime > t.filter_utime) {
    f.predict(utime_to_s(m.utime - t.filter_utime), params_.accel_psd);
    t.filter_utime = m.utime;
  }
  RangeNoise noise;
  const double r_cfg = params_.range_sigma_m * params_.range_sigma_m;
  const std::string& anchor_id = site_->anchors[anchor_index].id;
  const ConsistencyMonitor::LinkId link = noise_link(t, anchor_index);
  noise.r_var = consistency_.variance("RANGE", anchor_id, r_cfg, link);  // the link's
  noise.gate_chi2 = params_.gate_sigma * params_.gate_sigma;
  noise.gate_chi2_positive = params_.nlos_gate_sigma * params_.nlos_gate_sigma;
  noise.downweight_sigma = params_.nlos_downweight_sigma;
  // Likely NLOS by the receiver's own powers: trusted less, whatever its innovation says.
  const NlosPower nlos_model = params_.nlos_power();
  const double nlos_p = nlos_model.likelihood(m.rx_power_dbm, m.fp_power_dbm);
  noise.r_var *= nlos_model.variance_scale(nlos_p);
  // The pair's offset removed first: the gate judges what is left (an antenna delay is not NLOS);
  // its variance (once being learned) added to the range's.
  noise.r_var += t.bias.var_m2(anchor_index);
  const RangeUpdate r = range_update<D>(
      f, site_->anchors[anchor_index].position, t.height_m,
      t.bias.unscaled(anchor_index, corrected_range(m.range_m, params_.range_bias_m,
                                                    params_.range_bias_per_m)) -
          t.bias.offset_m(anchor_index),
      noise);

  consistency_.add_scalar("RANGE", anchor_id, utime_to_s(m.utime), r.innovation_m, r.hph, r_cfg,
                          !r.accepted, range_setting_, link);
  if (!r.accepted) {
    ++stats_.rejected_gate;
    if (++t.consecutive_rejections >= params_.reinit_after_rejections) t.initialised = false;
    // One anchor gated again and again while others are accepted: either it is NLOS, or the
    // track sits in a wrong minimum that the accepted anchors cannot tell from the truth (e.g. the
    // mirror image across the line of two anchors). on_range() checks with a fresh fix.
    if (++t.anchor_rejections[anchor_index] >= params_.reinit_after_rejections) {
      t.anchor_rejections[anchor_index] = 0;
      t.check_fix = true;
    }
    return;
  }
  t.anchor_rejections[anchor_index] = 0;
  if (r.downweighted) ++stats_.downweighted;
  if (nlos_p > 0.5) ++stats_.nlos_power;
  ++stats_.ranges_used;
  t.consecutive_rejections = 0;
  t.last_accept_utime = std::max(t.last_accept_utime, m.utime);
  t.tally.add(r.innovation_m);
}

ConsistencyMonitor::LinkId TwrEstimator::noise_link(Track& t, size_t anchor_index) {
  return consistency_.cached_link(t.noise_links, anchor_index, site_->anchors.size(), "RANGE",
                                  site_->anchors[anchor_index].id, t.tag_id);
}

utime_t TwrEstimator::epoch_window(const Track& t) const {
  // 1.2 rounds: the round's own jitter; at most half the coasting limit.
  return s_to_utime(std::max(params_.epoch_window_s,
                             std::min(1.2 * t.cycle_s, 0.5 * params_.max_coast_s)));
}

double TwrEstimator::range_offset_m(const std::string& tag_id,
                                    const std::string& anchor_id) const {
  const auto it = tracks_.find(tag_id);
  if (!site_ || it == tracks_.end()) return std::numeric_limits<double>::quiet_NaN();
  for (size_t k = 0; k < site_->anchors.size() && k < it->second.bias.size(); ++k)
    if (site_->anchors[k].id == anchor_id) return it->second.bias.offset_m(k);
  return std::numeric_limits<double>::quiet_NaN();
}

bool TwrEstimator::epoch_observations(const Track& t, utime_t now, bool learned,
                                      std::vector<RangeObservation>& obs) const {
  // The newest range per anchor within the epoch window.
  std::map<size_t, double> latest;
  for (const auto& e : t.recent)
    if (now - e.utime <= epoch_window(t)) latest[e.anchor_index] = e.range_m;
  obs.clear();
  for (const auto& [k, r] : latest) {
    double offset = t.bias.offset_m(k);
    if (!learned) {
      offset = pair_setting(params_.range_offsets_m, t.tag_id, site_->anchors[k].id);
      if (std::isnan(offset)) offset = 0;
    }
    obs.push_back({site_->anchors[k].position, r - offset});
  }
  const int dims = t.planar ? 2 : 3;
  return static_cast<int>(obs.size()) >= dims + 1;
}

void TwrEstimator::publish_epoch_fix(Track& t, const std::string& tag_id, utime_t now) {
  if (t.last_epoch_fix_utime != 0 &&
      now - t.last_epoch_fix_utime < s_to_utime(params_.publish_period_s))
    return;
  // Every anchor heard lately, as for a start (try_initialise): the plain solution of a full set.
  int heard = 0;
  for (utime_t last : t.anchor_heard_utime)
    heard += last != 0 && now - last <= s_to_utime(params_.max_coast_s);
  std::vector<RangeObservation> obs;
  if (!epoch_observations(t, now, false, obs) || static_cast<int>(obs.size()) < heard) return;
  MultilaterationOptions o;
  o.fixed_height = t.planar;
  o.height_m = t.height_m;
  const MultilaterationResult res = multilaterate(obs, o, params_.init_solver);
  if (!res.ok) return;
  t.last_epoch_fix_utime = now;
  pose_t p{};
  p.utime = now;
  p.source = source_ + "/epoch";
  p.tag_id = tag_id;
  const int dims = t.planar ? 2 : 3;
  const double var = std::max(params_.range_sigma_m * params_.range_sigma_m,
                              res.residual_rms_m * res.residual_rms_m);
  for (int k = 0; k < 3; ++k) p.position[k] = res.position(k);
  if (t.planar) p.position[2] = t.height_m;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      p.position_cov[3 * i + j] = i < dims && j < dims ? res.covariance_unit(i, j) * var : 0.0;
  for (double& v : p.velocity) v = std::numeric_limits<double>::quiet_NaN();
  p.heading_rad = std::numeric_limits<double>::quiet_NaN();
  p.num_used = static_cast<int32_t>(obs.size());
  p.residual_m = res.residual_rms_m;
  p.status = pose_t::STATUS_OK | (t.planar ? pose_t::STATUS_2D : 0);
  ++stats_.epoch_fixes_out;
  epoch_sink_(p);
}

void TwrEstimator::learn_offsets(Track& t, utime_t now) {
  // Only on a running track (its velocity moves the ranges to one time, its position picks the
  // minimum), one fix per epoch: consecutive fixes from overlapping epochs would share ranges.
  if (!t.initialised) return;
  if (t.last_bias_utime != 0 && now - t.last_bias_utime < epoch_window(t)) return;
  int heard = 0;
  for (utime_t last : t.anchor_heard_utime)
    heard += last != 0 && now - last <= s_to_utime(params_.max_coast_s);
  const int dims = t.planar ? 2 : 3;
  std::map<size_t, std::pair<utime_t, double>> latest;  // newest (time, range) per anchor
  for (const auto& e : t.recent)
    if (now - e.utime <= epoch_window(t)) latest[e.anchor_index] = {e.utime, e.range_m};
  // A residual needs a range more than the fix does; every anchor heard lately (one missing
  // would leave the fix free to absorb another's offset differently).
  const int m = static_cast<int>(latest.size());
  if (m < dims + 2 || m < heard) return;
  Eigen::Vector3d track = Eigen::Vector3d::Zero(), v = Eigen::Vector3d::Zero();
  double track_var = 0;
  if (t.planar) {
    track << t.f2.x(0), t.f2.x(1), t.height_m;
    v.head<2>() = t.f2.x.tail<2>();
    track_var = t.f2.P.topLeftCorner<2, 2>().trace();
  } else {
    track = t.f3.x.head<3>();
    v = t.f3.x.tail<3>();
    track_var = t.f3.P.topLeftCorner<3, 3>().trace();
  }
  std::vector<Eigen::Vector3d> positions;
  double r_var = 0;
  for (const auto& a : site_->anchors) {
    positions.push_back(a.position);
    r_var = std::max(r_var, consistency_.variance(
                                "RANGE", a.id, params_.range_sigma_m * params_.range_sigma_m,
                                noise_link(t, static_cast<size_t>(&a - site_->anchors.data()))));
  }
  t.last_bias_utime = now;
  learn_offsets_from_epoch(t.bias, latest, positions, now, track, v, track_var, dims,
                           params_.range_sigma_m, r_var, 1.0 - 1.0 / params_.bias_window,
                           params_.bias_max_m, params_.init_solver);
}

bool TwrEstimator::try_initialise(Track& t, utime_t now, bool only_if_elsewhere) {
  std::vector<RangeObservation> obs;
  epoch_observations(t, now, true, obs);
  const int dims = t.planar ? 2 : 3;
  // Wait for an epoch with every anchor the tag has been heard by lately: with one range less
  // than it could have, a wrong local minimum (the mirror image across two anchors' line) can fit
  // as well as the truth.
  int heard = 0;
  for (utime_t last : t.anchor_heard_utime)
    heard += last != 0 && now - last <= s_to_utime(params_.max_coast_s);
  int required = std::max(dims + 1, heard);
  // A new track has not heard every anchor yet: give the rest one second (and two epochs) to
  // show up before starting from the bare minimum.
  if (now - t.first_utime < std::max<utime_t>(1'000'000, 2 * s_to_utime(params_.epoch_window_s)))
    required = std::max(required, std::min(dims + 2, enabled_uwb_anchors_));
  if (static_cast<int>(obs.size()) < required) return false;
  MultilaterationOptions o;
  o.fixed_height = t.planar;
  o.height_m = t.height_m;
  const double max_residual = 3.0 * params_.range_sigma_m + 0.2;
  const MultilaterationResult res =
      multilaterate_dropping_one(obs, o, params_.init_solver, max_residual);
  if (!res.ok) return false;
  if (only_if_elsewhere) {
    // Every anchor agrees on a fix the track's covariance does not cover: the track is wrong.
    const Eigen::VectorXd track =
        t.planar ? Eigen::VectorXd(t.f2.x.head<2>()) : Eigen::VectorXd(t.f3.x.head<3>());
    const double spread = t.planar ? std::sqrt(t.f2.P.topLeftCorner<2, 2>().trace())
                                   : std::sqrt(t.f3.P.topLeftCorner<3, 3>().trace());
    if ((res.position.head(dims) - track).norm() <=
        std::max(1.0, params_.gate_sigma * spread))
      return false;
  }

  // A start no spare range could check may hold an NLOS range of a metre or more.
  const double sigma = static_cast<int>(obs.size()) <= dims + 1
                           ? kUncheckedStartSigmaM
                           : std::max(params_.range_sigma_m, res.residual_rms_m);
  const double v_var = params_.init_velocity_sigma_mps * params_.init_velocity_sigma_mps;
  auto init = [&](auto& f) {
    f.x.setZero();
    f.P.setZero();
    for (int k = 0; k < dims; ++k) f.x(k) = res.position(k);
    f.P.topLeftCorner(dims, dims) =
        res.covariance_unit.topLeftCorner(dims, dims) * sigma * sigma +
        Eigen::MatrixXd::Identity(dims, dims) * 0.01;
    f.P.bottomRightCorner(dims, dims) = Eigen::MatrixXd::Identity(dims, dims) * v_var;
  };
  if (t.planar)
    init(t.f2);
  else
    init(t.f3);
  t.initialised = true;
  ++stats_.initialisations;
  t.filter_utime = now;
  t.last_accept_utime = now;
  t.consecutive_rejections = 0;
  t.tally.restart(static_cast<int>(obs.size()), res.residual_rms_m);
  std::fill(t.anchor_rejections.begin(), t.anchor_rejections.end(), 0);
  return true;
}

template <int D>
void TwrEstimator::publish(Track& t, const CvFilter<D>& f, const std::string& tag_id, utime_t now) {
  if (!t.tally.due(now, params_.publish_period_s)) return;
  pose_t p;
  p.utime = now;
  p.source = source_;
  p.tag_id = tag_id;
  fill_pose_from_cv<D>(f, t.height_m, p);
  t.tally.finish(p, D == 2, now);
  ++stats_.poses_out;
  sink_(p);
}

}  // namespace ips::uwb_twr
