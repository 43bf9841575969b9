#include "estimators/uwb_tdoa/tdoa_estimator.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>

#include "estimators/uwb_tdoa/counter_wrap.hpp"
#include "estimators/uwb_tdoa/models/tdoa.hpp"
#include "estimators/uwb_tdoa/tdoa_least_squares.hpp"

#include "core/track_limit.hpp"

namespace ips::uwb_tdoa {

namespace {

// Anchors of one blink used at most (the nearest ones): the reference and kMaxTdoaPerEpoch more.
constexpr size_t kMaxArrivals = kMaxTdoaPerEpoch + 1;

bool is_tdoa_anchor(const Site& site, const std::string& id) {
  const Anchor* a = site.find_anchor(id);
  return a && a->enabled && a->kind == "uwb_tdoa";
}

}  // namespace

TdoaParams parse_tdoa_params(const YamlField& s, const Site& site) {
  TdoaParams p;
  if (!s.defined()) return p;
  if (!s.is_map()) s.fail("expected a map of uwb_tdoa parameters");
  s.check_keys({"mode",
                "master",
                "reference",
                "update",
                "rx_sigma_ns",
                "sync_sigma_ns",
                "learn_noise",
                "rate_random_walk_ppb_per_sqrt_s",
                "initial_rate_sigma_ppb",
                "sync_gate_sigma",
                "reacquire_after_rejections",
                "clock_lost_after_s",
                "sync_match_window_s",
                "accel_psd",
                "gate_sigma",
                "epoch_window_s",
                "init_velocity_sigma_mps",
                "init_max_residual_m",
                "reinit_after_rejections",
                "max_coast_s",
                "publish_period_s",
                "reorder_tolerance_s",
                "max_tags",
                "pair_sigma_m",
                "pair_gate_sigma",
                "pair_lost_level",
                "pair_lost_share",
                "pair_window_s"});
  // Every parameter is bounded, not just positive: a SITE message on the bus is outside input.
  auto in_range = [&](const char* key, double& v, double lo, double hi) {
    v = s.get_double(key, v);
    if (!(v > lo && v <= hi)) {
      auto text = [](double x) {
        char buf[32];
        std::snprintf(buf, sizeof buf, "%g", x);
        return x == 1e6 ? std::string("1e6") : std::string(buf);
      };
      s[key].fail("must be in (" + text(lo) + ", " + text(hi) + "]");
    }
  };
  auto count = [&](const char* key, int& v, int lo, int hi) {
    const int64_t n = s.get_int(key, v);
    if (n < lo || n > hi)
      s[key].fail("must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    v = static_cast<int>(n);
  };
  const std::string mode = s.get_string("mode", "auto");
  if (mode != "auto" && mode != "3d")
    s["mode"].fail("expected auto (2D when the tag height is known) or 3d");
  p.force_3d = mode == "3d";

  p.clock.master = s.get_string("master", "");
  if (!p.clock.master.empty() && !is_tdoa_anchor(site, p.clock.master))
    s["master"].fail("'" + p.clock.master + "' is not an enabled uwb_tdoa anchor of the site");
  const std::string reference = s.get_string("reference", "nearest");
  if (reference == "nearest") {
    p.reference = ReferenceChoice::kNearest;
  } else if (reference == "master") {
    p.reference = ReferenceChoice::kMaster;
  } else if (is_tdoa_anchor(site, reference)) {
    p.reference = ReferenceChoice::kAnchor;
    p.reference_anchor = reference;
  } else {
    s["reference"].fail(
        "expected nearest, master or an enabled uwb_tdoa anchor of the site, got '" + reference +
        "'");
  }
  const std::string update = s.get_string("update", "vector");
  if (update != "vector" && update != "sequential")
    s["update"].fail("expected vector or sequential");
  p.sequential = update == "sequential";

  in_range("rx_sigma_ns", p.rx_sigma_ns, 0, 1e6);
  in_range("sync_sigma_ns", p.clock.sync_sigma_ns, 0, 1e6);
  p.learn_noise = s.get_bool("learn_noise", p.learn_noise);
  in_range("rate_random_walk_ppb_per_sqrt_s", p.clock.rate_random_walk_ppb_per_sqrt_s, 0, 1e6);
  in_range("initial_rate_sigma_ppb", p.clock.initial_rate_sigma_ppb, 0, 1e6);
  in_range("sync_gate_sigma", p.clock.gate_sigma, 0, 1e6);
  count("reacquire_after_rejections", p.clock.reacquire_after_rejections, 1, 1000000);
  in_range("clock_lost_after_s", p.clock.lost_after_s, 0, 1e6);
  // Half a counter wrap (8.6 s): a sync report cannot be matched across more.
  in_range("sync_match_window_s", p.clock.match_window_s, 0, 8);
  in_range("accel_psd", p.accel_psd, 0, 1e6);
  in_range("gate_sigma", p.gate_sigma, 0, 1e6);
  in_range("epoch_window_s", p.epoch_window_s, 0, 8);
  in_range("init_velocity_sigma_mps", p.init_velocity_sigma_mps, 0, 1e6);
  in_range("init_max_residual_m", p.init_max_residual_m, 0, 1e6);
  count("reinit_after_rejections", p.reinit_after_rejections, 1, 1000000);
  in_range("max_coast_s", p.max_coast_s, 0, 1e6);
  in_range("publish_period_s", p.publish_period_s, 0, 1e6);
  in_range("reorder_tolerance_s", p.reorder_tolerance_s, 0, 1e6);
  count("max_tags", p.max_tags, 1, 100000);
  in_range("pair_sigma_m", p.pairs.pair_sigma_m, 0, 100);
  in_range("pair_gate_sigma", p.pairs.pair_gate_sigma, 0, 1e6);
  in_range("pair_lost_level", p.pairs.pair_lost_level, 0, 1e6);
  in_range("pair_window_s", p.pairs.pair_window_s, 0, 60);
  in_range("pair_lost_share", p.pairs.pair_lost_share, 0, 0.95);
  p.pairs.force_3d = p.force_3d;
  p.pairs.accel_psd = p.accel_psd;
  p.pairs.init_velocity_sigma_mps = p.init_velocity_sigma_mps;
  p.pairs.init_max_residual_m = p.init_max_residual_m;
  p.pairs.max_coast_s = p.max_coast_s;
  p.pairs.publish_period_s = p.publish_period_s;
  p.pairs.reorder_tolerance_s = p.reorder_tolerance_s;
  p.pairs.max_tags = p.max_tags;
  return p;
}

TdoaEstimator::TdoaEstimator(PoseSink pose_sink, ClockSink clock_sink, std::string source_name)
    : pose_sink_(std::move(pose_sink)),
      source_(std::move(source_name)),
      clocks_(std::move(clock_sink), source_),
      pairs_([this](const pose_t& p) { pose_sink_(p); }, source_) {
  arrivals_.reserve(64);
}

void TdoaEstimator::set_epoch_sink(EpochSink sink, bool track) {
  epoch_sink_ = std::move(sink);
  track_ = track;
}

void TdoaEstimator::set_site(const Site& site) {
  TdoaParams p = parse_tdoa_params(site.estimator_params("uwb_tdoa"), site);
  params_ = std::move(p);
  // Syncs learn each anchor's noise; differences are checked, not learned: their variance comes
  // from the clock filters.
  ConsistencyOptions co;
  co.learn = params_.learn_noise;
  consistency_ = ConsistencyMonitor(co);
  consistency_.monitor_only("TDOA");
  clocks_.set_consistency(&consistency_);
  pairs_.configure(site, params_.pairs, &consistency_);
  // A difference's variance is the receptions' and the clocks' (sync_sigma_ns): either may be off.
  rx_setting_ = setting_text("rx_sigma_ns", params_.rx_sigma_ns) + " or " +
                setting_text("sync_sigma_ns", params_.clock.sync_sigma_ns);
  site_ = site;
  clocks_.configure(params_.clock, *site_);
  reference_anchor_ = params_.reference == ReferenceChoice::kAnchor
                          ? clocks_.anchor_index(params_.reference_anchor)
                          : -1;
  counter_hz_ = 0;
  tracks_.clear();
  open_order_.clear();
}

DropReasons TdoaEstimator::drop_reasons() const {
  const ClockSyncStats& c = clocks_.stats();
  const PairStats& pr = pairs_.stats();
  DropReasons d;
  d.add(DropReason::kNoSite, stats_.dropped_no_site + pr.pairs_no_site);
  d.add(DropReason::kNoAnchorsOfKind, stats_.dropped_no_anchors);
  d.add(DropReason::kUnknownAnchor, stats_.dropped_unknown_anchor + pr.pairs_unknown_anchor);
  d.add(DropReason::kInvalid, stats_.dropped_invalid + pr.pairs_invalid);
  d.add(DropReason::kLate, stats_.dropped_late + c.dropped_late + pr.pairs_late);
  d.add(DropReason::kTimeJump, guard_.dropped());
  d.add(DropReason::kDuplicate, stats_.dropped_duplicate + c.dropped_duplicate);
  d.add(DropReason::kTooManyTags, stats_.dropped_too_many_tags + pr.pairs_too_many_tags);
  d.add(DropReason::kNoClock, stats_.rx_no_clock);
  d.add(DropReason::kUnmatchedSync, c.dropped_unmatched + c.dropped_other_master);
  d.add(DropReason::kTooFewAnchors, stats_.epochs_too_few);
  d.add(DropReason::kInitialising, stats_.epochs_initialising + pr.pairs_initialising);
  d.add(DropReason::kGated, stats_.rejected_gate + stats_.rejected_geometry + c.rejected_gate +
                                pr.pairs_gated + pr.pairs_geometry);
  return d;
}

void TdoaEstimator::on_rx(const uwb_rx_t& m) {
  ++stats_.rx_in;
  if (!site_) {
    ++stats_.dropped_no_site;
    return;
  }
  if (!plausible_utime(m.utime) || !valid_counter(m.rx_counter) || m.anchor_id.empty() ||
      m.sender_id.empty() || !(m.counter_hz >= 1e6 && m.counter_hz <= 1e12)) {
    ++stats_.dropped_invalid;
    return;
  }
  // One counter frequency for the whole system (the first report's): the clocks are tracked in
  // its ticks.
  if (counter_hz_ == 0) counter_hz_ = m.counter_hz;
  if (std::abs(m.counter_hz - counter_hz_) > 1e-9 * counter_hz_) {
    ++stats_.dropped_invalid;
    return;
  }
  if (clocks_.anchor_index(m.anchor_id) < 0) {
    ++(clocks_.num_anchors() == 0 ? stats_.dropped_no_anchors : stats_.dropped_unknown_anchor);
    return;
  }
  // A stamp far from its anchor's timeline waits for confirmation (core/time_guard.hpp): one
  // reception stamped ahead closed every open blink and became the clocks' newest. An anchor
  // whose host clock went back restarts the clocks and the tracks (intervals across are
  // nonsense).
  if (!guard_.admit(m.anchor_id, m.utime, [this, m] { on_rx(m); }, [this] {
        clocks_.restart();
        tracks_.clear();
        open_order_.clear();
      })) {
    --stats_.rx_in;  // counted when handed over again, or dropped as a time jump
    return;
  }
  close_expired(m.utime);
  if (m.is_sync) {
    clocks_.on_sync(m, counter_hz_);
    return;
  }
  ++stats_.blinks_in;
  if (site_->find_anchor(m.sender_id)) {
    ++stats_.dropped_invalid;  // an anchor is not a tag
    return;
  }
  auto it = tracks_.find(m.sender_id);
  if (it == tracks_.end()) {
    // A track silent for 10 coast periods makes room (core/track_limit.hpp).
    if (!room_for_track(tracks_, m.utime, params_.max_tags,
                        10 * s_to_utime(params_.max_coast_s))) {
      ++stats_.dropped_too_many_tags;
      return;
    }
    it = tracks_.try_emplace(m.sender_id).first;
    Track& t = it->second;
    const Tag* tag = site_->find_tag(m.sender_id);
    t.planar = !params_.force_3d && tag && std::isfinite(tag->height_m);
    t.height_m = t.planar ? tag->height_m : 0.0;
    t.blink.rx.reserve(static_cast<size_t>(clocks_.num_anchors()));
  }
  const std::string& tag_id = it->first;
  Track& t = it->second;
  if (t.newest_utime != 0) {
    const utime_t behind = t.newest_utime - m.utime;
    if (behind > s_to_utime(params_.max_coast_s)) {
      // Time went back further than any reordering explains (a clock step, a replay restarted):
      // start this track afresh rather than drop forever.
      ++stats_.time_resets;
      Track fresh;
      fresh.planar = t.planar;
      fresh.height_m = t.height_m;
      fresh.blink.rx.reserve(static_cast<size_t>(clocks_.num_anchors()));
      t = std::move(fresh);
    } else if (behind > s_to_utime(params_.reorder_tolerance_s)) {
      ++stats_.dropped_late;
      return;
    }
  }
  const utime_t window = s_to_utime(params_.epoch_window_s);
  if (t.has_closed && m.seq == t.closed_seq && std::llabs(m.utime - t.closed_utime) <= window) {
    // An anchor's report of a blink already processed: that anchor's again is a copy (a LAN
    // duplicates datagrams: routine); another anchor's is a straggler, too late for it.
    const int a = clocks_.anchor_index(m.anchor_id);
    if (a < 64 && (t.closed_anchors >> a & 1U) != 0) {
      ++stats_.dropped_duplicate;
    } else {
      ++stats_.dropped_late;
    }
    return;
  }
  // A report of another blink, or of this seq long after (a seq reused), closes the open one.
  if (t.open && (m.seq != t.blink.seq || m.utime - t.blink.utime > window)) close_blink(tag_id, t);
  if (!t.open) {
    t.open = true;
    t.blink.seq = m.seq;
    t.blink.utime = m.utime;
    t.blink.rx.clear();
    open_order_.emplace_back(m.utime, tag_id);
    // Bounded even when host time stands still while blinks pour in.
    while (open_order_.size() > 2 * static_cast<size_t>(params_.max_tags) + 16)
      open_order_.pop_front();
  }
  const int anchor = clocks_.anchor_index(m.anchor_id);
  for (const auto& r : t.blink.rx) {
    if (r.anchor == anchor) {
      ++stats_.dropped_duplicate;
      return;
    }
  }
  t.blink.rx.push_back({anchor, m.rx_counter});
  t.newest_utime = std::max(t.newest_utime, m.utime);
  // Every anchor has reported: nothing more can come.
  if (static_cast<int>(t.blink.rx.size()) == clocks_.num_anchors()) close_blink(tag_id, t);
}

void TdoaEstimator::close_expired(utime_t now) {
  const utime_t window = s_to_utime(params_.epoch_window_s);
  while (!open_order_.empty() && now - open_order_.front().first > window) {
    const auto [opened, tag_id] = open_order_.front();
    open_order_.pop_front();
    auto it = tracks_.find(tag_id);
    if (it != tracks_.end() && it->second.open && it->second.blink.utime == opened)
      close_blink(it->first, it->second);
  }
}

void TdoaEstimator::flush() {
  for (auto& [tag_id, t] : tracks_)
    if (t.open) close_blink(tag_id, t);
  open_order_.clear();
}

void TdoaEstimator::close_blink(const std::string& tag_id, Track& t) {
  t.open = false;
  t.has_closed = true;
  t.closed_seq = t.blink.seq;
  t.closed_utime = t.blink.utime;
  t.closed_anchors = 0;
  for (const auto& r : t.blink.rx)
    if (r.anchor >= 0 && r.anchor < 64) t.closed_anchors |= uint64_t{1} << r.anchor;
  process(tag_id, t, t.blink);
}

Eigen::Vector3d TdoaEstimator::track_position(const Track& t) const {
  if (t.planar) return {t.f2.x(0), t.f2.x(1), t.height_m};
  return t.f3.x.head<3>();
}

void TdoaEstimator::process(const std::string& tag_id, Track& t, const Blink& b) {
  ++stats_.epochs;
  const double rx_var_s2 = params_.rx_sigma_ns * params_.rx_sigma_ns * 1e-18;
  arrivals_.clear();
  for (const auto& r : b.rx) {
    const std::optional<MasterTime> mt = clocks_.to_master(r.anchor, r.counter, b.utime);
    if (!mt) {
      ++stats_.rx_no_clock;
      continue;
    }
    arrivals_.push_back(
        {r.anchor, mt->ticks, (rx_var_s2 + mt->var_s2) * kSpeedOfLightMps * kSpeedOfLightMps});
  }
  if (arrivals_.size() < 2) {
    ++stats_.epochs_too_few;
    return;
  }
  if (epoch_sink_) {
    std::sort(arrivals_.begin(), arrivals_.end(), [](const Arrival& a, const Arrival& b2) {
      return counter_diff(a.ticks, b2.ticks) < 0;
    });
    TdoaEpoch e;
    e.tag_id = &tag_id;
    e.utime = b.utime;
    const double m_per_tick = kSpeedOfLightMps / counter_hz_;
    for (const Arrival& a : arrivals_) {
      if (e.count == kMaxEpochArrivals) break;
      e.anchor[e.count] = clocks_.anchor_position(a.anchor);
      e.range_m[e.count] = counter_diff(a.ticks, arrivals_.front().ticks) * m_per_tick;
      e.var_m2[e.count] = a.var_m2;
      ++e.count;
    }
    epoch_sink_(e);
  }
  if (!track_) return;
  if (t.initialised && b.utime - t.last_accept_utime > s_to_utime(params_.max_coast_s))
    t.initialised = false;
  if (!t.initialised) {
    if (!try_initialise(t, b, arrivals_)) {
      ++stats_.epochs_initialising;
      return;
    }
    if (t.planar)
      publish<2>(t, t.f2, tag_id, b.utime);
    else
      publish<3>(t, t.f3, tag_id, b.utime);
    return;
  }
  if (t.planar) {
    update<2>(t, t.f2, b, arrivals_);
    publish<2>(t, t.f2, tag_id, b.utime);
  } else {
    update<3>(t, t.f3, b, arrivals_);
    publish<3>(t, t.f3, tag_id, b.utime);
  }
}

bool TdoaEstimator::try_initialise(Track& t, const Blink& b, const std::vector<Arrival>& arr) {
  const int dims = t.planar ? 2 : 3;
  // One difference more than unknowns, so that the fix's residual can expose a bad one.
  if (static_cast<int>(arr.size()) < dims + 2) return false;
  // Reference: the earliest arrival (the nearest anchor, whatever the clocks' offsets).
  size_t ref = 0;
  for (size_t k = 1; k < arr.size(); ++k)
    if (counter_diff(arr[k].ticks, arr[ref].ticks) < 0) ref = k;
  const double m_per_tick = kSpeedOfLightMps / counter_hz_;
  std::array<Eigen::Vector3d, 16> anchors;
  std::array<double, 15> diffs;
  anchors[0] = clocks_.anchor_position(arr[ref].anchor);
  size_t n = 0;
  double var_sum = 0;
  for (size_t k = 0; k < arr.size() && n < diffs.size(); ++k) {
    if (k == ref) continue;
    const Eigen::Vector3d& a = clocks_.anchor_position(arr[k].anchor);
    const double z = counter_diff(arr[k].ticks, arr[ref].ticks) * m_per_tick;
    // |d_k - d_ref| <= |a_k - a_ref| (triangle inequality), up to the noise.
    if (std::abs(z) >
        (a - anchors[0]).norm() + 5.0 * std::sqrt(arr[k].var_m2 + arr[ref].var_m2) + 0.5) {
      ++stats_.rejected_geometry;
      continue;
    }
    anchors[n + 1] = a;
    diffs[n] = z;
    var_sum += arr[k].var_m2 + arr[ref].var_m2;
    ++n;
  }
  if (static_cast<int>(n) < dims + 1) return false;
  TdoaFixOptions o;
  o.fixed_height = t.planar;
  o.height_m = t.height_m;
  const TdoaFix fix =
      solve_tdoa_fix(std::span(anchors.data(), n + 1), std::span(diffs.data(), n), o);
  // A large residual means a bad difference in the set: wait for a cleaner epoch.
  if (!fix.ok || fix.residual_rms_m > params_.init_max_residual_m) return false;

  const double var =
      std::max(var_sum / static_cast<double>(n), fix.residual_rms_m * fix.residual_rms_m);
  const double v_var = params_.init_velocity_sigma_mps * params_.init_velocity_sigma_mps;
  auto init = [&](auto& f, int d) {
    f.x.setZero();
    f.P.setZero();
    for (int k = 0; k < d; ++k) f.x(k) = fix.position(k);
    f.P.topLeftCorner(d, d) =
        fix.covariance_unit.topLeftCorner(d, d) * var + Eigen::MatrixXd::Identity(d, d) * 0.01;
    f.P.bottomRightCorner(d, d) = Eigen::MatrixXd::Identity(d, d) * v_var;
  };
  if (t.planar)
    init(t.f2, 2);
  else
    init(t.f3, 3);
  t.initialised = true;
  ++stats_.initialisations;
  stats_.tdoa_used += static_cast<int64_t>(n);
  t.filter_utime = b.utime;
  t.last_accept_utime = b.utime;
  t.consecutive_rejections = 0;
  t.tally.restart(static_cast<int>(n), fix.residual_rms_m);
  return true;
}

template <int D>
void TdoaEstimator::update(Track& t, CvFilter<D>& f, const Blink& b, std::vector<Arrival>& arr) {
  if (b.utime > t.filter_utime) {
    f.predict(utime_to_s(b.utime - t.filter_utime), params_.accel_psd);
    t.filter_utime = b.utime;
  }
  // Reference preference: the chosen anchor first, then the others by distance from the
  // estimate (the nearest has the strongest, most likely direct, path).
  const Eigen::Vector3d p = track_position(t);
  const int preferred = params_.reference == ReferenceChoice::kMaster   ? clocks_.master_index()
                        : params_.reference == ReferenceChoice::kAnchor ? reference_anchor_
                                                                        : -1;
  auto key = [&](const Arrival& a) {
    if (a.anchor == preferred) return -1.0;
    return (clocks_.anchor_position(a.anchor) - p).squaredNorm();
  };
  std::sort(arr.begin(), arr.end(),
            [&](const Arrival& a, const Arrival& b2) { return key(a) < key(b2); });
  if (arr.size() > kMaxArrivals) arr.resize(kMaxArrivals);

  const double m_per_tick = kSpeedOfLightMps / counter_hz_;
  const double gate_chi2 = params_.gate_sigma * params_.gate_sigma;
  struct Gated {
    std::array<TdoaRow<D>, kMaxTdoaPerEpoch> rows;
    std::array<double, kMaxTdoaPerEpoch> y, z, var;
    std::array<int, kMaxTdoaPerEpoch> idx;
    int accepted = 0, rejected = 0, geometry = 0;
    // Every difference's innovation, for the consistency monitor.
    struct Seen {
      int k;
      double y, hph, var;
      bool gated;
    };
    std::array<Seen, kMaxArrivals> seen;
    int n_seen = 0;
  };
  // Gates every difference to reference arr[r] on its own innovation.
  auto gate_with = [&](size_t r, Gated& g) {
    const Eigen::Vector3d& ar = clocks_.anchor_position(arr[r].anchor);
    for (size_t k = 0; k < arr.size(); ++k) {
      if (k == r) continue;
      const Eigen::Vector3d& ak = clocks_.anchor_position(arr[k].anchor);
      const double z = counter_diff(arr[k].ticks, arr[r].ticks) * m_per_tick;
      const double var = arr[k].var_m2;
      if (std::abs(z) > (ak - ar).norm() + 5.0 * std::sqrt(var + arr[r].var_m2) + 0.5) {
        ++g.geometry;
        continue;
      }
      const TdoaRow<D> row = tdoa_row<D>(f.x, t.height_m, ak, ar);
      const double y = z - row.predicted;
      const double hph = (row.H * f.P * row.H.transpose())(0, 0);
      const double S = hph + var + arr[r].var_m2;
      const bool gated = !(y * y <= gate_chi2 * S);
      g.seen[static_cast<size_t>(g.n_seen++)] = {static_cast<int>(k), y, hph, var + arr[r].var_m2, gated};
      if (gated) {
        ++g.rejected;
        continue;
      }
      const int i = g.accepted++;
      g.rows[i] = row;
      g.y[i] = y;
      g.z[i] = z;
      g.var[i] = var;
      g.idx[i] = static_cast<int>(k);
    }
  };
  Gated g;
  size_t ref = 0;
  gate_with(0, g);
  // Most differences gated: the reference itself is probably the outlier; try the next anchor.
  if (g.accepted < g.rejected + g.geometry && arr.size() >= 3) {
    Gated g2;
    gate_with(1, g2);
    if (g2.accepted > g.accepted) {
      g = g2;
      ref = 1;
    }
  }
  stats_.rejected_geometry += g.geometry;
  for (int i = 0; i < g.n_seen; ++i) {
    const auto& e = g.seen[static_cast<size_t>(i)];
    consistency_.add_scalar("TDOA", clocks_.anchor_id(arr[static_cast<size_t>(e.k)].anchor),
                            utime_to_s(b.utime), e.y, e.hph, e.var, e.gated, rx_setting_);
  }
  // A blink whose differences mostly disagree with the track says the track is wrong more than
  // that they are: the few that pass are not applied either (they would drag a lost track
  // further), and enough such blinks in a row restart it from a fresh fix.
  if (g.accepted == 0 || g.accepted < g.rejected + g.geometry) {
    stats_.rejected_gate += g.rejected + g.accepted;
    if (++t.consecutive_rejections >= params_.reinit_after_rejections) t.initialised = false;
    return;
  }
  stats_.rejected_gate += g.rejected;
  double sq = 0;
  int used = 0;
  if (params_.sequential) {
    const Eigen::Vector3d& ar = clocks_.anchor_position(arr[ref].anchor);
    for (int i = 0; i < g.accepted; ++i) {
      double innovation = 0;
      const UpdateResult res =
          tdoa_update<D>(f, t.height_m, clocks_.anchor_position(arr[g.idx[i]].anchor), ar, g.z[i],
                         g.var[i] + arr[ref].var_m2, gate_chi2, &innovation);
      if (!res.accepted) {
        ++stats_.rejected_gate;
        continue;
      }
      ++used;
      sq += innovation * innovation;
    }
  } else {
    const UpdateResult res = tdoa_vector_update<D>(f, g.rows.data(), g.y.data(), g.var.data(),
                                                   arr[ref].var_m2, g.accepted);
    if (res.accepted) {
      used = g.accepted;
      for (int i = 0; i < g.accepted; ++i) sq += g.y[i] * g.y[i];
    } else {
      stats_.rejected_gate += g.accepted;
    }
  }
  if (used == 0) {
    if (++t.consecutive_rejections >= params_.reinit_after_rejections) t.initialised = false;
    return;
  }
  stats_.tdoa_used += used;
  t.consecutive_rejections = 0;
  t.last_accept_utime = std::max(t.last_accept_utime, b.utime);
  t.tally.add_many(static_cast<int>(used), sq);
}

template <int D>
void TdoaEstimator::publish(Track& t, const CvFilter<D>& f, const std::string& tag_id,
                            utime_t now) {
  if (!t.tally.due(now, params_.publish_period_s)) return;
  pose_t p;
  p.utime = now;
  p.source = source_;
  p.tag_id = tag_id;
  fill_pose_from_cv<D>(f, t.height_m, p);
  t.tally.finish(p, D == 2, now);
  ++stats_.poses_out;
  pose_sink_(p);
}

}  // namespace ips::uwb_tdoa
