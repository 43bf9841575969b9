// UWB TDoA as real anchors report it (UWB_RX, uwb_rx_t): every enabled `uwb_tdoa` anchor
// timestamps what it receives with its own free-running 40-bit counter at 63.8976 GHz
// (499.2 MHz x 128, the DW1000 of source 004 §1), which wraps every 2^40 / 63.8976e9 = 17.207 s.
//
// - Anchor clocks: reading(t) = t + offset0 + drift0 * t + W(t) for the true time t since the
//   scenario start. offset0 is uniform over one counter wrap, drift0 uniform in
//   +-drift_max_ppb (004 §3: rate coefficients between anchors span 1.000000000 to
//   1.000000090), W the integral of an optional rate random walk (Gaussian steps every
//   second, linear in between). Any anchor's offset0/drift0 can be fixed under `clocks:`.
// - The sync master (`master:`) broadcasts every sync_period_s (2 s, 004 §2.2). Every other
//   anchor reports the reception (is_sync, sender_id = master) after the master-to-anchor time
//   of flight; the master reports the counter at which it sent the sync (004 §1, its `E`
//   record), without reception noise and never lost.
// - Each walker's tag blinks every 1/blink_rate_hz (100 ms in 004 §1); every anchor within
//   max_range_m, and in line of sight when a room_outline is given, reports it.
// - A reception has Gaussian timestamp noise, rx_noise_sigma_ns (default sqrt(3e-20 s^2) =
//   0.17 ns: the ToA measurement variance R of the clock Kalman filter of 004 §2.3, model 4),
//   and is lost with loss_probability.
// - utime is the host time at which the report arrives: emission time + report_latency_s. All
//   reports of one emission share it, so events stay in time order; the physics is in
//   rx_counter.
//
// Ground truth of the clocks is a deterministic function of the section, the site and the seed:
// uwb_tdoa_clock_truth() below.
#include <algorithm>
#include <cmath>
#include <ips/uwb_rx_t.hpp>
#include <memory>

#include "core/channels.hpp"
#include "drivers/sim/models/uwb_tdoa.hpp"
#include "drivers/sim/sensor_model.hpp"

namespace ips::sim {

namespace {

constexpr double kSpeedOfLightMps = 299792458.0;
constexpr double kCounterHz = 63.8976e9;
constexpr int64_t kCounterModulus = int64_t{1} << 40;
constexpr int64_t kTicksPer10Us = 638976;  // kCounterHz * 1e-5, exact
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

struct ClockSetting {
  std::string anchor_id;
  double offset_s = kNaN;  // NaN: drawn
  double drift_ppb = kNaN;
};

struct UwbTdoaParams {
  std::string master;  // default: the first enabled uwb_tdoa anchor
  double blink_rate_hz = 10.0;
  double sync_period_s = 2.0;
  double rx_noise_sigma_ns = 0.17;
  double loss_probability = 0.0;
  double max_range_m = 100.0;
  double drift_max_ppb = 45.0;
  double drift_random_walk_ppb_per_sqrt_s = 0.0;
  double report_latency_s = 0.002;
  std::vector<ClockSetting> clocks;
  std::vector<Eigen::Vector2d> room_outline;  // empty: no walls
};

// One anchor's clock (see the file comment). Queried at non-decreasing times (the simulator
// fires events in time order); a query up to a time of flight before the current 1 s knot
// extrapolates the current segment, an error of order sigma_walk * (1 us)^2.
class AnchorClock {
 public:
  AnchorClock(const UwbTdoaParams& p, const ClockSetting* setting, std::mt19937_64 rng)
      : rng_(std::move(rng)), walk_sigma_(p.drift_random_walk_ppb_per_sqrt_s * 1e-9) {
    // Draw both whether or not they are fixed, so fixing one anchor changes no other value.
    std::uniform_int_distribution<int64_t> ticks(0, kCounterModulus - 1);
    std::uniform_real_distribution<double> uni(-1.0, 1.0);
    offset0_s_ = static_cast<double>(ticks(rng_)) / kCounterHz;
    drift0_ = uni(rng_) * p.drift_max_ppb * 1e-9;
    if (setting && !std::isnan(setting->offset_s)) offset0_s_ = setting->offset_s;
    if (setting && !std::isnan(setting->drift_ppb)) drift0_ = setting->drift_ppb * 1e-9;
    if (walk_sigma_ > 0) w_next_ = walk_sigma_ * std::normal_distribution<double>(0.0, 1.0)(rng_);
  }

  double offset_s(double t_s) {
    const double u = advance_to(t_s);
    return offset0_s_ + drift0_ * t_s + walk_integral_ + w_ * u + 0.5 * (w_next_ - w_) * u * u;
  }
  double rate(double t_s) {
    const double u = advance_to(t_s);
    return drift0_ + w_ + (w_next_ - w_) * u;
  }

 private:
  // Moves to the 1 s segment holding t_s; returns t_s minus the segment start.
  double advance_to(double t_s) {
    while (walk_sigma_ > 0 && t_s >= static_cast<double>(knot_ + 1)) {
      walk_integral_ += 0.5 * (w_ + w_next_);
      w_ = w_next_;
      w_next_ = w_ + walk_sigma_ * std::normal_distribution<double>(0.0, 1.0)(rng_);
      ++knot_;
    }
    return t_s - static_cast<double>(knot_);
  }

  std::mt19937_64 rng_;
  double walk_sigma_;  // rate step per 1 s knot
  double offset0_s_ = 0.0;
  double drift0_ = 0.0;
  int64_t knot_ = 0;            // current segment [knot_, knot_ + 1) s
  double walk_integral_ = 0.0;  // W at knot_
  double w_ = 0.0;              // walk rate at knot_ and at knot_ + 1
  double w_next_ = 0.0;
};

// Counter reading of a clock at the true time t_us (integer us since start) + extra_s (time of
// flight and noise). t_us * 63897.6 is split off in integer arithmetic so that the counter stays
// exact to a tick for scenarios of any length (a double holds only 2^53 ticks = 39 hours).
int64_t counter_at(int64_t t_us, double extra_s, double clock_offset_s) {
  const int64_t whole = (t_us / 10) % kCounterModulus * kTicksPer10Us;
  const double frac = static_cast<double>(t_us % 10) * (kCounterHz * 1e-6) +
                      (extra_s + clock_offset_s) * kCounterHz;
  const int64_t ticks = whole + static_cast<int64_t>(std::floor(frac));
  return ((ticks % kCounterModulus) + kCounterModulus) % kCounterModulus;
}

double cross(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return a.x() * b.y() - a.y() * b.x();
}

// True when the plan-view path a-b properly crosses an edge of the room outline (full-height
// walls). Touching a corner does not block.
bool crosses_outline(const std::vector<Eigen::Vector2d>& outline, const Eigen::Vector2d& a,
                     const Eigen::Vector2d& b) {
  for (size_t i = 0; i < outline.size(); ++i) {
    const Eigen::Vector2d& c = outline[i];
    const Eigen::Vector2d& d = outline[(i + 1) % outline.size()];
    const double o1 = cross(b - a, c - a), o2 = cross(b - a, d - a);
    const double o3 = cross(d - c, a - c), o4 = cross(d - c, b - c);
    if (((o1 > 0 && o2 < 0) || (o1 < 0 && o2 > 0)) && ((o3 > 0 && o4 < 0) || (o3 < 0 && o4 > 0)))
      return true;
  }
  return false;
}

// What every source of the model shares: parameters, anchors and their clocks.
struct TdoaNetwork {
  UwbTdoaParams p;
  std::vector<const Anchor*> anchors;  // enabled uwb_tdoa anchors
  std::vector<AnchorClock> clocks;     // one per anchor
  size_t master = 0;                   // index into anchors
  int64_t latency_us = 0;
};

// A reception's two random values, drawn whether or not it is lost.
struct RxDraws {
  double u_loss;
  double noise_s;
};
RxDraws draw(std::mt19937_64& rng, double sigma_s) {
  const double u = std::uniform_real_distribution<double>(0.0, 1.0)(rng);
  const double n = std::normal_distribution<double>(0.0, 1.0)(rng);
  return {u, sigma_s * n};
}

void fill_report(uwb_rx_t& m, utime_t t, const std::string& anchor, const std::string& sender,
                 bool is_sync, int32_t seq, int64_t counter) {
  m.utime = t;
  m.source = kSimSource;
  m.anchor_id = anchor;
  m.sender_id = sender;
  m.is_sync = is_sync;
  m.seq = seq;
  m.rx_counter = counter;
  m.counter_hz = kCounterHz;
  m.rx_power_dbm = m.fp_power_dbm = m.quality = std::numeric_limits<float>::quiet_NaN();
}

// One emitter (a tag's blinks or the master's syncs): each emission is reported by every anchor
// in turn, so next_us() returns the same time once per anchor.
class EmissionSource : public SensorSource {
 public:
  EmissionSource(std::shared_ptr<TdoaNetwork> net, int64_t period_us, int64_t phase_us,
                 std::vector<std::mt19937_64> rngs)
      : net_(std::move(net)), period_us_(period_us), phase_us_(phase_us), rngs_(std::move(rngs)) {}

  int64_t next_us() const override { return emission_us() + net_->latency_us; }

  bool fire(utime_t start, SimEvent& ev) override {
    const int64_t t_us = emission_us();
    const size_t i = anchor_;
    const bool received = receive(i, t_us, start + t_us + net_->latency_us, ev);
    if (++anchor_ == net_->anchors.size()) {
      anchor_ = 0;
      ++count_;
    }
    return received;
  }

 protected:
  // Fills ev with anchor i's report of the emission at t_us; false when it is not received.
  virtual bool receive(size_t i, int64_t t_us, utime_t report_utime, SimEvent& ev) = 0;

  int64_t emission_us() const { return phase_us_ + count_ * period_us_; }
  int32_t seq() const { return static_cast<int32_t>(count_ & 0x7fffffff); }
  bool first_anchor() const { return anchor_ == 0; }

  // Anchor i's report of a signal that reaches it distance_m after the emission at t_us.
  bool report(size_t i, int64_t t_us, double distance_m, bool path_ok, bool exact,
              utime_t report_utime, const std::string& sender, bool is_sync, SimEvent& ev) {
    const TdoaNetwork& n = *net_;
    const RxDraws d = draw(rngs_[i], n.p.rx_noise_sigma_ns * 1e-9);
    if (!exact && (!path_ok || distance_m > n.p.max_range_m || d.u_loss < n.p.loss_probability))
      return false;
    const double tof_s = distance_m / kSpeedOfLightMps;
    const double t_rx_s = utime_to_s(t_us) + tof_s;
    const int64_t counter =
        counter_at(t_us, tof_s + (exact ? 0.0 : d.noise_s), net_->clocks[i].offset_s(t_rx_s));
    fill_report(msg_, report_utime, n.anchors[i]->id, sender, is_sync, seq(), counter);
    encode_event(msg_, report_utime, channel::kUwbRx, ev);
    return true;
  }

  std::shared_ptr<TdoaNetwork> net_;

 private:
  int64_t period_us_;
  int64_t phase_us_;
  std::vector<std::mt19937_64> rngs_;  // one per (sender, anchor)
  int64_t count_ = 0;
  size_t anchor_ = 0;
  uwb_rx_t msg_;
};

class BlinkSource : public EmissionSource {
 public:
  BlinkSource(std::shared_ptr<TdoaNetwork> net, const TagTrajectory& walker, int64_t period_us,
              int64_t phase_us, std::vector<std::mt19937_64> rngs)
      : EmissionSource(std::move(net), period_us, phase_us, std::move(rngs)), walker_(walker) {}

 protected:
  bool receive(size_t i, int64_t t_us, utime_t report_utime, SimEvent& ev) override {
    if (first_anchor()) tag_position_ = walker_.path.at(utime_to_s(t_us)).position;
    const Anchor& a = *net_->anchors[i];
    const bool path_ok =
        net_->p.room_outline.empty() ||
        !crosses_outline(net_->p.room_outline, tag_position_.head<2>(), a.position.head<2>());
    return report(i, t_us, (tag_position_ - a.position).norm(), path_ok, false, report_utime,
                  walker_.tag_id, false, ev);
  }

 private:
  const TagTrajectory& walker_;
  Eigen::Vector3d tag_position_ = Eigen::Vector3d::Zero();
};

class SyncSource : public EmissionSource {
 public:
  SyncSource(std::shared_ptr<TdoaNetwork> net, std::vector<std::mt19937_64> rngs)
      : EmissionSource(net, s_to_utime(net->p.sync_period_s), 0, std::move(rngs)) {
    const TdoaNetwork& n = *net_;
    const Anchor& m = *n.anchors[n.master];
    for (const Anchor* a : n.anchors) {
      distance_m_.push_back((a->position - m.position).norm());
      path_ok_.push_back(
          n.p.room_outline.empty() ||
          !crosses_outline(n.p.room_outline, m.position.head<2>(), a->position.head<2>()));
    }
  }

 protected:
  bool receive(size_t i, int64_t t_us, utime_t report_utime, SimEvent& ev) override {
    const TdoaNetwork& n = *net_;
    // The master's own record is its transmit counter: exact, and not a radio reception.
    return report(i, t_us, distance_m_[i], path_ok_[i], i == n.master, report_utime,
                  n.anchors[n.master]->id, true, ev);
  }

 private:
  std::vector<double> distance_m_;  // master to each anchor
  std::vector<bool> path_ok_;
};

// Parses the section and builds the network (anchors, parameters and clocks).
std::shared_ptr<TdoaNetwork> make_network(const YamlField& f, const SimWorld& world) {
  f.check_keys({"enabled", "master", "blink_rate_hz", "sync_period_s", "rx_noise_sigma_ns",
                "loss_probability", "max_range_m", "drift_max_ppb",
                "drift_random_walk_ppb_per_sqrt_s", "report_latency_s", "clocks", "room_outline"});
  auto net = std::make_shared<TdoaNetwork>();
  UwbTdoaParams& p = net->p;
  p.blink_rate_hz = param_in_range(f, "blink_rate_hz", p.blink_rate_hz, 0.01, 1000);
  // Longer than one counter wrap, a sync interval could not be unwrapped.
  p.sync_period_s = param_in_range(f, "sync_period_s", p.sync_period_s, 0.01, 17);
  p.rx_noise_sigma_ns = param_in_range(f, "rx_noise_sigma_ns", p.rx_noise_sigma_ns, 0, 1000);
  p.loss_probability = param_in_range(f, "loss_probability", p.loss_probability, 0, 1);
  p.max_range_m = param_in_range(f, "max_range_m", p.max_range_m, 0, 1e6);
  p.drift_max_ppb = param_in_range(f, "drift_max_ppb", p.drift_max_ppb, 0, 1e5);
  p.drift_random_walk_ppb_per_sqrt_s = param_in_range(f, "drift_random_walk_ppb_per_sqrt_s",
                                                      p.drift_random_walk_ppb_per_sqrt_s, 0, 100);
  p.report_latency_s = param_in_range(f, "report_latency_s", p.report_latency_s, 0, 1);
  net->latency_us = s_to_utime(p.report_latency_s);

  for (const auto& a : world.site.anchors)
    if (a.kind == "uwb_tdoa" && a.enabled) net->anchors.push_back(&a);
  if (net->anchors.empty()) f.fail("no enabled uwb_tdoa anchor in site.anchors");
  auto index_of = [&](const std::string& id) -> size_t {
    for (size_t i = 0; i < net->anchors.size(); ++i)
      if (net->anchors[i]->id == id) return i;
    return net->anchors.size();
  };

  p.master = f.get_string("master", net->anchors.front()->id);
  net->master = index_of(p.master);
  if (net->master == net->anchors.size())
    f["master"].fail("'" + p.master + "' is not an enabled uwb_tdoa anchor of the site");

  const YamlField clocks = f["clocks"];
  if (clocks.defined()) {
    if (!clocks.is_map()) clocks.fail("expected a map: anchor id -> {offset_s, drift_ppb}");
    for (const auto& kv : clocks.node()) {
      const std::string id = kv.first.IsScalar() ? kv.first.Scalar() : "?";
      const YamlField c = clocks[id];
      if (index_of(id) == net->anchors.size())
        c.fail("'" + id + "' is not an enabled uwb_tdoa anchor of the site");
      if (!c.is_map()) c.fail("expected a map {offset_s, drift_ppb}");
      c.check_keys({"offset_s", "drift_ppb"});
      ClockSetting s;
      s.anchor_id = id;
      if (c["offset_s"].defined()) s.offset_s = param_in_range(c, "offset_s", 0, 0, 17.2);
      if (c["drift_ppb"].defined()) s.drift_ppb = param_in_range(c, "drift_ppb", 0, -1e5, 1e5);
      p.clocks.push_back(s);
    }
  }

  const YamlField outline = f["room_outline"];
  if (outline.defined()) {
    if (!outline.is_sequence() || outline.size() < 3)
      outline.fail("expected a polygon of at least 3 points [x, y]");
    for (size_t k = 0; k < outline.size(); ++k) {
      p.room_outline.push_back(outline[k].as_vec2());
      if (p.room_outline.back().cwiseAbs().maxCoeff() > 1e6)
        outline[k].fail("coordinates must be within 1e6 m");
    }
  }

  for (const Anchor* a : net->anchors) {
    const ClockSetting* setting = nullptr;
    for (const auto& s : p.clocks)
      if (s.anchor_id == a->id) setting = &s;
    net->clocks.emplace_back(p, setting, stream_rng(world.seed, "UWB_RX_CLOCK " + a->id));
  }
  return net;
}

SourceList make(const YamlField& f, const SimWorld& world) {
  std::shared_ptr<TdoaNetwork> net = make_network(f, world);
  auto rngs_for = [&](const std::string& sender) {
    std::vector<std::mt19937_64> rngs;
    for (const Anchor* a : net->anchors)
      rngs.push_back(
          stream_rng(world.seed, std::string(channel::kUwbRx) + " " + sender + " " + a->id));
    return rngs;
  };
  SourceList out;
  out.push_back(std::make_unique<SyncSource>(net, rngs_for(net->p.master)));
  // Tags blink on staggered phases, 1 ms after the first sync, as free-running tags would.
  const int64_t period = period_us(net->p.blink_rate_hz);
  const auto n = static_cast<int64_t>(std::max<size_t>(1, world.walkers.size()));
  int64_t k = 0;
  for (const auto& w : world.walkers)
    out.push_back(std::make_unique<BlinkSource>(net, w, period, 1000 + (k++ * period) / n,
                                                rngs_for(w.tag_id)));
  return out;
}

}  // namespace

UwbTdoaClockTruth uwb_tdoa_clock_truth(const YamlField& section, const SimWorld& world,
                                       const std::string& anchor_id, double t_s) {
  std::shared_ptr<TdoaNetwork> net = make_network(section, world);
  for (size_t i = 0; i < net->anchors.size(); ++i)
    if (net->anchors[i]->id == anchor_id)
      return {net->clocks[i].offset_s(t_s), net->clocks[i].rate(t_s) * 1e9};
  throw ConfigError("uwb_tdoa: '" + anchor_id + "' is not an enabled uwb_tdoa anchor of the site");
}

SensorModel uwb_tdoa_sensor_model() { return {"uwb_tdoa", &make}; }

}  // namespace ips::sim
