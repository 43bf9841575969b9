#include "drivers/sim/simulator.hpp"

#include <cmath>
#include <ips/pose_t.hpp>
#include <ips/site_t.hpp>
#include <ips/uwb_range_t.hpp>
#include <limits>

namespace ips::sim {

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr const char* kSource = "ips-sim";

template <class Msg>
void encode_into(const Msg& msg, std::vector<uint8_t>& out) {
  out.resize(static_cast<size_t>(msg.getEncodedSize()));
  msg.encode(out.data(), 0, static_cast<int>(out.size()));
}

// Rates are validated to [0.01, 1000] Hz by the scenario parser; the clamp keeps any period >= 1 us.
int64_t period_us(double rate_hz) { return std::max<utime_t>(1, s_to_utime(1.0 / rate_hz)); }

// FNV-1a: a stable hash of a source's name, so that each source's noise stream depends on what
// it is (e.g. "UWB_RANGE T1 A3"), not on how many other sources there are.
uint64_t stream_key(const std::string& name) {
  uint64_t h = 14695981039346656037ULL;
  for (unsigned char c : name) h = (h ^ c) * 1099511628211ULL;
  return h;
}
}  // namespace

Simulator::Simulator(Scenario scenario, uint64_t seed, utime_t start_utime)
    : sc_(std::move(scenario)),
      start_(start_utime),
      end_(start_utime + s_to_utime(sc_.duration_s)),
      range_seq_(sc_.trajectories.size(), 0) {
  // Each source draws from its own stream, keyed by its name, so that adding a sensor, a tag or
  // an anchor does not change the noise of the others.
  auto make_rng = [&](const std::string& name) {
    const uint64_t key = stream_key(name);
    std::seed_seq seq{static_cast<uint32_t>(seed), static_cast<uint32_t>(seed >> 32),
                      static_cast<uint32_t>(key), static_cast<uint32_t>(key >> 32)};
    return std::mt19937_64(seq);
  };
  sources_.push_back({Kind::kSite, 0, 0, period_us(1.0 / sc_.site_period_s), 0, 0, make_rng("SITE")});
  for (size_t i = 0; i < sc_.trajectories.size(); ++i) {
    sources_.push_back({Kind::kTruth, i, 0, period_us(sc_.truth.rate_hz), 0, 0,
                        make_rng("TRUTH " + sc_.trajectories[i].tag_id)});
  }
  if (sc_.uwb_twr.enabled) {
    const int64_t p = period_us(sc_.uwb_twr.rate_hz);
    std::vector<size_t> anchors;
    for (size_t a = 0; a < sc_.site.anchors.size(); ++a)
      if (sc_.site.anchors[a].kind == "uwb" && sc_.site.anchors[a].enabled) anchors.push_back(a);
    // Ranging is time-multiplexed: each (tag, anchor) pair gets its own slot within the period.
    const int64_t slots = static_cast<int64_t>(anchors.size() * sc_.trajectories.size());
    int64_t slot = 0;
    for (size_t i = 0; i < sc_.trajectories.size(); ++i)
      for (size_t a : anchors)
        sources_.push_back({Kind::kUwbRange, i, a, p, (slot++ * p) / std::max<int64_t>(1, slots) + 1000,
                            0,
                            make_rng("UWB_RANGE " + sc_.trajectories[i].tag_id + " " +
                                     sc_.site.anchors[a].id)});
  }
}

bool Simulator::next(SimEvent& ev) {
  for (;;) {
    Source* best = nullptr;
    for (auto& s : sources_)
      if (!best || s.next_us() < best->next_us()) best = &s;
    if (!best) return false;
    const utime_t t = start_ + best->next_us();
    if (t > end_) return false;
    ++best->count;
    switch (best->kind) {
      case Kind::kSite:
        emit_site(t, ev);
        return true;
      case Kind::kTruth:
        emit_truth(*best, t, ev);
        return true;
      case Kind::kUwbRange:
        if (emit_range(*best, t, ev)) return true;
        break;
    }
  }
}

void Simulator::emit_site(utime_t t, SimEvent& ev) {
  ev.utime = t;
  ev.kind = "SITE";
  encode_into(site_to_msg(sc_.site, t, kSource), ev.data);
}

void Simulator::emit_truth(Source& s, utime_t t, SimEvent& ev) {
  const auto& traj = sc_.trajectories[s.traj];
  const TrajectoryState st = traj.path.at(utime_to_s(t - start_));
  pose_t m;
  m.utime = t;
  m.source = "truth";
  m.tag_id = traj.tag_id;
  for (int k = 0; k < 3; ++k) {
    m.position[k] = st.position[k];
    m.velocity[k] = st.velocity[k];
  }
  for (double& c : m.position_cov) c = 0.0;
  m.heading_rad = st.heading_rad;
  m.num_used = 0;
  m.residual_m = kNaN;
  m.status = pose_t::STATUS_OK;
  ev.utime = t;
  ev.kind = "TRUTH";
  encode_into(m, ev.data);
}

bool Simulator::emit_range(Source& s, utime_t t, SimEvent& ev) {
  const auto& model = sc_.uwb_twr;
  const auto& traj = sc_.trajectories[s.traj];
  const auto& anchor = sc_.site.anchors[s.anchor];
  const TrajectoryState st = traj.path.at(utime_to_s(t - start_));
  const double true_range = (st.position - anchor.position).norm();
  // Draw every random number whether or not the range survives, so that the stream stays aligned.
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  std::normal_distribution<double> gauss(0.0, 1.0);
  const double u_loss = uni(s.rng);
  const double u_nlos = uni(s.rng);
  const double u_bias = uni(s.rng);
  const double noise = gauss(s.rng);
  int32_t seq = range_seq_[s.traj]++;
  if (u_loss < model.loss_probability || true_range > model.max_range_m) return false;
  double r = true_range + model.bias_m + model.noise_sigma_m * noise;
  if (u_nlos < model.nlos_probability)
    r += model.nlos_bias_min_m + u_bias * (model.nlos_bias_max_m - model.nlos_bias_min_m);
  uwb_range_t m;
  m.utime = t;
  m.source = kSource;
  m.tag_id = traj.tag_id;
  m.anchor_id = anchor.id;
  m.range_m = std::max(0.0, r);
  m.rx_power_dbm = std::numeric_limits<float>::quiet_NaN();
  m.fp_power_dbm = std::numeric_limits<float>::quiet_NaN();
  m.quality = std::numeric_limits<float>::quiet_NaN();
  m.seq = seq;
  ev.utime = t;
  ev.kind = "UWB_RANGE";
  encode_into(m, ev.data);
  return true;
}

}  // namespace ips::sim
