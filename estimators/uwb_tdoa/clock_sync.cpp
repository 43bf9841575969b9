#include "estimators/uwb_tdoa/clock_sync.hpp"

#include <algorithm>
#include <cmath>

#include "estimators/uwb_tdoa/counter_wrap.hpp"

namespace ips::uwb_tdoa {

namespace {
constexpr size_t kMasterRecordsKept = 8;
}

ClockSync::ClockSync(ClockSink sink, std::string source)
    : sink_(std::move(sink)), source_(std::move(source)) {}

void ClockSync::configure(const ClockSyncParams& params, const Site& site) {
  params_ = params;
  sync_setting_ = setting_text("sync_sigma_ns", params.sync_sigma_ns);
  anchors_.clear();
  for (const auto& a : site.anchors) {
    if (a.kind != "uwb_tdoa" || !a.enabled) continue;
    AnchorClock c;
    c.id = a.id;
    c.position = a.position;
    anchors_.push_back(std::move(c));
  }
  master_ = -1;
  master_records_seen_ = 0;
  newest_master_utime_ = 0;
  reset_clocks();
  if (!params_.master.empty()) set_master(anchor_index(params_.master));
}

int ClockSync::anchor_index(const std::string& id) const {
  for (size_t i = 0; i < anchors_.size(); ++i)
    if (anchors_[i].id == id) return static_cast<int>(i);
  return -1;
}

const std::string& ClockSync::master_id() const {
  static const std::string kNone;
  return master_ >= 0 ? anchors_[master_].id : kNone;
}

double ClockSync::q_ppb2_per_s() const {
  return params_.rate_random_walk_ppb_per_sqrt_s * params_.rate_random_walk_ppb_per_sqrt_s;
}

void ClockSync::set_master(int i) {
  master_ = i;
  if (i < 0) return;
  // 004 §2.2: TOF = |r_master - r_anchor| / c, assuming the direct path.
  for (auto& a : anchors_) a.tof_s = (a.position - anchors_[i].position).norm() / kSpeedOfLightMps;
}

void ClockSync::reset_clocks() {
  for (auto& a : anchors_) {
    a.started = false;
    a.status = ClockStatus::kAcquiring;
    a.num_syncs = 0;
    a.consecutive_rejections = 0;
  }
  master_records_.clear();
  pending_.clear();
}

void ClockSync::on_sync(const uwb_rx_t& m, double counter_hz) {
  ++stats_.syncs_in;
  hz_ = counter_hz;
  expire_pending(m.utime);
  const int anchor = anchor_index(m.anchor_id);
  const int sender = anchor_index(m.sender_id);
  if (anchor < 0 || sender < 0) {
    ++stats_.dropped_other_master;
    return;
  }
  if (master_ < 0) set_master(sender);
  if (sender != master_) {
    // A forced master is never replaced. Otherwise the master is whoever sends the syncs: when
    // the current one has been silent for lost_after_s and another is sending, it takes over.
    if (params_.master.empty() &&
        m.utime - newest_master_utime_ > s_to_utime(params_.lost_after_s)) {
      ++stats_.master_changes;
      set_master(sender);
      master_records_seen_ = 0;
      newest_master_utime_ = 0;
      reset_clocks();
    } else {
      ++stats_.dropped_other_master;
      return;
    }
  }
  if (anchor == sender)
    on_master_record(m);
  else
    on_reception(anchor, m);
}

void ClockSync::expire_pending(utime_t now) {
  const utime_t window = s_to_utime(params_.match_window_s);
  for (auto it = pending_.begin(); it != pending_.end();) {
    if (now - it->utime > window) {
      ++stats_.dropped_unmatched;
      it = pending_.erase(it);
    } else {
      ++it;
    }
  }
}

void ClockSync::on_master_record(const uwb_rx_t& m) {
  const utime_t window = s_to_utime(params_.match_window_s);
  if (newest_master_utime_ != 0 &&
      m.utime < newest_master_utime_ - std::max(window, s_to_utime(1.0))) {
    // Further back than any reordering explains: one stale or bogus stamp, dropped (a real step
    // back of the host clock is confirmed by the caller's time guard, which calls restart()).
    ++stats_.dropped_late;
    return;
  }
  for (const auto& r : master_records_) {
    if (r.seq == m.seq && std::llabs(r.utime - m.utime) <= window) {
      ++stats_.dropped_duplicate;
      return;
    }
  }
  ++stats_.master_records;
  ++master_records_seen_;
  const MasterRecord rec{m.seq, m.rx_counter, m.utime};
  master_records_.push_back(rec);
  while (master_records_.size() > kMasterRecordsKept) master_records_.pop_front();
  newest_master_utime_ = std::max(newest_master_utime_, m.utime);

  clock_t c;
  c.utime = m.utime;
  c.source = source_;
  c.anchor_id = c.master_id = anchors_[master_].id;
  c.offset_s = c.offset_std_s = c.rate_ppb = c.rate_std_ppb = 0.0;
  c.num_syncs = master_records_seen_;
  c.status = static_cast<int32_t>(ClockStatus::kTracking);
  ++stats_.clocks_out;
  sink_(c);

  for (auto it = pending_.begin(); it != pending_.end();) {
    if (it->seq == rec.seq && std::llabs(it->utime - rec.utime) <= window) {
      const PendingRx p = *it;
      it = pending_.erase(it);
      apply(p.anchor, rec, p.counter);
    } else {
      ++it;
    }
  }
  // Clocks that have not had a sync for lost_after_s are lost: reported once per master record
  // until a sync re-acquires them.
  for (int i = 0; i < num_anchors(); ++i) {
    AnchorClock& a = anchors_[i];
    if (i == master_ || !a.started) continue;
    if (m.utime - a.last_accept_utime > s_to_utime(params_.lost_after_s)) {
      a.status = ClockStatus::kLost;
      publish(a, m.utime);
    }
  }
}

void ClockSync::on_reception(int anchor, const uwb_rx_t& m) {
  const utime_t window = s_to_utime(params_.match_window_s);
  for (auto it = master_records_.rbegin(); it != master_records_.rend(); ++it) {
    if (it->seq == m.seq && std::llabs(it->utime - m.utime) <= window) {
      apply(anchor, *it, m.rx_counter);
      return;
    }
  }
  for (const auto& p : pending_) {
    if (p.anchor == anchor && p.seq == m.seq) {
      ++stats_.dropped_duplicate;
      return;
    }
  }
  // Its master record may still come (reports of one sync arrive in any order). Bounded: a
  // flood of unmatched receptions pushes out the oldest.
  pending_.push_back({anchor, m.seq, m.rx_counter, m.utime});
  while (pending_.size() > 4 * anchors_.size() + 16) {
    pending_.pop_front();
    ++stats_.dropped_unmatched;
  }
}

void ClockSync::acquire(AnchorClock& a, const MasterRecord& rec, int64_t rx_counter) {
  const double offset_ticks =
      static_cast<double>(counter_diff(rx_counter, rec.counter)) - a.tof_s * hz_;
  const double whole = std::round(offset_ticks);
  a.base_ticks = counter_mod(static_cast<int64_t>(whole));
  a.x << (offset_ticks - whole) / hz_ * 1e9, 0.0;
  a.P.setZero();
  a.P(0, 0) = params_.sync_sigma_ns * params_.sync_sigma_ns;
  a.P(1, 1) = params_.initial_rate_sigma_ppb * params_.initial_rate_sigma_ppb;
  a.started = true;
  a.num_syncs = 1;
  a.status = a.num_syncs >= params_.tracking_after_syncs ? ClockStatus::kTracking
                                                         : ClockStatus::kAcquiring;
  a.consecutive_rejections = 0;
  a.last_accept_utime = rec.utime;
  a.ref_master_counter = rec.counter;
  a.ref_utime = rec.utime;
  a.ref_seq = rec.seq;
  ++stats_.acquisitions;
  ++stats_.syncs_used;
}

void ClockSync::apply(int anchor, const MasterRecord& rec, int64_t rx_counter) {
  AnchorClock& a = anchors_[anchor];
  if (!a.started || a.status == ClockStatus::kLost ||
      rec.utime - a.last_accept_utime > s_to_utime(params_.lost_after_s)) {
    acquire(a, rec, rx_counter);
    publish(a, rec.utime);
    return;
  }
  // Master time elapsed since the clock's reference sync: the modular difference of the master's
  // transmit counters, with the whole wraps counted from host time (a gap of missed syncs).
  const int64_t d_mod = counter_mod(rec.counter - a.ref_master_counter);
  if (d_mod == 0 && rec.seq == a.ref_seq) {
    ++stats_.dropped_duplicate;
    return;
  }
  const double approx = utime_to_s(rec.utime - a.ref_utime) * hz_;
  const double elapsed_ticks = unwrap_near(static_cast<double>(d_mod), approx);
  if (elapsed_ticks <= 0) {
    ++stats_.dropped_late;
    return;
  }
  // Predict: offset += rate * dt (ns += ppb * s), rate random walk with PSD q:
  // Q = q [dt^3/3, dt^2/2; dt^2/2, dt] (004 §2.3 model 4's A = [1 dt; 0 1]).
  const double dt = elapsed_ticks / hz_;
  Mat<2> F;
  F << 1.0, dt, 0.0, 1.0;
  a.x = F * a.x;
  const double q = q_ppb2_per_s();
  Mat<2> Q;
  Q << q * dt * dt * dt / 3.0, q * dt * dt / 2.0, q * dt * dt / 2.0, q * dt;
  a.P = F * a.P * F.transpose() + Q;
  a.ref_master_counter = rec.counter;
  a.ref_utime = rec.utime;
  a.ref_seq = rec.seq;

  // Measurement: anchor rx counter - master tx counter - time of flight, in ns relative to the
  // base, reduced modulo 2^40 (the offset is known far better than half a wrap).
  const int64_t master_plus_base = counter_mod(rec.counter + a.base_ticks);
  const double z_ns =
      (static_cast<double>(counter_diff(rx_counter, master_plus_base)) - a.tof_s * hz_) / hz_ * 1e9;
  Mat<1, 2> H;
  H << 1.0, 0.0;
  const double r_cfg = params_.sync_sigma_ns * params_.sync_sigma_ns;
  const double r = monitor_ ? monitor_->variance("SYNC", a.id, r_cfg) : r_cfg;
  const double innovation = z_ns - a.x(0), hph = a.P(0, 0);
  const UpdateResult res =
      scalar_update<2>(a.x, a.P, H, innovation, r, params_.gate_sigma * params_.gate_sigma);
  if (monitor_)
    monitor_->add_scalar("SYNC", a.id, utime_to_s(rec.utime), innovation, hph, r_cfg, !res.accepted,
                         sync_setting_);
  if (!res.accepted) {
    ++stats_.rejected_gate;
    if (++a.consecutive_rejections >= params_.reacquire_after_rejections) {
      // The clock jumped (an anchor reset) or was wrong: start again from this sync.
      ++stats_.reacquisitions;
      acquire(a, rec, rx_counter);
    }
    publish(a, rec.utime);
    return;
  }
  ++stats_.syncs_used;
  a.consecutive_rejections = 0;
  ++a.num_syncs;
  a.last_accept_utime = rec.utime;
  if (a.num_syncs >= params_.tracking_after_syncs) a.status = ClockStatus::kTracking;
  // Whole ticks into the base, so that the filter's offset stays within a tick.
  const double shift = std::round(a.x(0) * 1e-9 * hz_);
  a.base_ticks = counter_mod(a.base_ticks + static_cast<int64_t>(shift));
  a.x(0) -= shift / hz_ * 1e9;
  publish(a, rec.utime);
}

std::optional<MasterTime> ClockSync::to_master(int i, int64_t counter, utime_t utime) const {
  if (i < 0 || i >= num_anchors() || master_ < 0) return std::nullopt;
  if (i == master_) return MasterTime{static_cast<double>(counter), 0.0};
  const AnchorClock& a = anchors_[i];
  if (!a.started || a.status != ClockStatus::kTracking ||
      utime - a.last_accept_utime > s_to_utime(params_.lost_after_s))
    return std::nullopt;
  // The anchor's counter at the reference sync, then the anchor ticks elapsed since (whole wraps
  // from host time), turned into master ticks by dividing by (1 + rate).
  const double anchor_at_ref = counter_mod(
      static_cast<double>(counter_mod(a.ref_master_counter + a.base_ticks)) + a.x(0) * 1e-9 * hz_);
  const double d = counter_diff(static_cast<double>(counter), anchor_at_ref);
  const double elapsed_anchor = unwrap_near(d, utime_to_s(utime - a.ref_utime) * hz_);
  const double elapsed_master = elapsed_anchor / (1.0 + a.x(1) * 1e-9);
  const double dt = elapsed_master / hz_;
  // Variance of offset(ref + dt) = [1 dt] P [1 dt]' plus the rate random walk over |dt|.
  const double var_ns2 = a.P(0, 0) + 2.0 * dt * a.P(0, 1) + dt * dt * a.P(1, 1) +
                         q_ppb2_per_s() * std::abs(dt * dt * dt) / 3.0;
  return MasterTime{counter_mod(static_cast<double>(a.ref_master_counter) + elapsed_master),
                    var_ns2 * 1e-18};
}

ClockEstimate ClockSync::make_estimate(const AnchorClock& a) const {
  ClockEstimate e;
  e.anchor_id = a.id;
  e.offset_s = counter_diff(static_cast<double>(a.base_ticks) + a.x(0) * 1e-9 * hz_, 0.0) / hz_;
  e.offset_std_s = std::sqrt(std::max(0.0, a.P(0, 0))) * 1e-9;
  e.rate_ppb = a.x(1);
  e.rate_std_ppb = std::sqrt(std::max(0.0, a.P(1, 1)));
  e.num_syncs = a.num_syncs;
  e.status = a.status;
  e.utime = a.ref_utime;
  return e;
}

std::optional<ClockEstimate> ClockSync::estimate(const std::string& anchor_id) const {
  const int i = anchor_index(anchor_id);
  if (i < 0 || master_ < 0) return std::nullopt;
  if (i == master_) {
    ClockEstimate e;
    e.anchor_id = anchor_id;
    e.num_syncs = master_records_seen_;
    e.status = ClockStatus::kTracking;
    e.utime = newest_master_utime_;
    return e;
  }
  if (!anchors_[i].started) return std::nullopt;
  return make_estimate(anchors_[i]);
}

void ClockSync::publish(const AnchorClock& a, utime_t utime) {
  const ClockEstimate e = make_estimate(a);
  clock_t c;
  c.utime = utime;
  c.source = source_;
  c.anchor_id = a.id;
  c.master_id = master_id();
  c.offset_s = e.offset_s;
  c.offset_std_s = e.offset_std_s;
  c.rate_ppb = e.rate_ppb;
  c.rate_std_ppb = e.rate_std_ppb;
  c.num_syncs = e.num_syncs;
  c.status = static_cast<int32_t>(e.status);
  ++stats_.clocks_out;
  sink_(c);
}

}  // namespace ips::uwb_tdoa
