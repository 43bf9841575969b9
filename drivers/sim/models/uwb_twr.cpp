// UWB two-way ranging between every enabled `uwb` anchor and every walker (UWB_RANGE):
// Gaussian noise, a constant bias, NLOS with a uniform positive bias, packet loss and a maximum
// range. NLOS comes either as independent outliers (nlos_episode_s 0) or as episodes: a two-state
// Markov chain per (tag, anchor) pair whose stationary NLOS share is nlos_probability and whose
// mean episode length is nlos_episode_s, with one bias per episode (a person or a pillar blocking
// the direct path for a while). Ranging is time-multiplexed: each pair has its own slot; the rate
// can be set per anchor.
// Anchor-to-anchor ranging (anchor_pairs_rate_hz > 0), the input of ips-uwb-survey: every
// unordered pair of enabled `uwb` anchors ranges with the same error model, published as a real
// network does it, with the first anchor (site order) acting as the initiator: tag_id = its id.
// These sources draw from streams named "UWB_RANGE_PAIR A B", so turning them on leaves every
// tag stream (and every other model's) exactly as it was.
// Biased radios, two ways, which add: a constant offset per ranging pair (pair_offset_min_m /
// max_m), and an antenna delay per device (device_delay_min_m / max_m), a range reading long by
// the delays of both its ends, tag-anchor and anchor-anchor alike (the model ips-uwb-survey
// --offsets inverts).
#include <algorithm>
#include <ips/uwb_range_t.hpp>

#include "drivers/sim/sensor_model.hpp"

namespace ips::sim {

namespace {

struct UwbTwrParams {
  double rate_hz = 10.0;          // per anchor and tag
  double noise_sigma_m = 0.10;    // Gaussian
  double bias_m = 0.0;            // constant
  double nlos_probability = 0.0;  // per range
  double nlos_bias_min_m = 0.3;   // NLOS adds a uniform positive bias in [min, max]
  double nlos_bias_max_m = 1.5;
  double loss_probability = 0.0;
  double max_range_m = 100.0;
  double nlos_episode_s = 0.0;    // 0: independent outliers; > 0: mean NLOS episode length
  double anchor_pairs_rate_hz = 0.0;  // per anchor pair; 0: no anchor-to-anchor ranging
  // A biased radio: each pair's own constant offset, uniform in [min, max] (real DW1000 pairs:
  // +0.08 to +0.32 m, antenna delays); 0 and 0: none.
  double pair_offset_min_m = 0.0;
  double pair_offset_max_m = 0.0;
  // Each device's (tag's or anchor's) antenna delay as a distance, uniform in [min, max]; a range
  // reads long by the sum of its two ends' delays. 0 and 0: none.
  double device_delay_min_m = 0.0;
  double device_delay_max_m = 0.0;
};

// One ranging pair: a walker's tag, or an anchor acting as the initiator, to an anchor.
class UwbTwrSource : public PeriodicSource {
 public:
  UwbTwrSource(const UwbTwrParams& p, double rate_hz, const TagTrajectory& walker,
               const Anchor& anchor, int64_t phase_us, std::mt19937_64 rng, double offset_m)
      : PeriodicSource(period_us(rate_hz), phase_us),
        p_(p),
        offset_m_(offset_m),
        dt_s_(1.0 / rate_hz),
        initiator_id_(walker.tag_id),
        walker_(&walker),
        anchor_(anchor),
        rng_(std::move(rng)) {}
  UwbTwrSource(const UwbTwrParams& p, double rate_hz, const Anchor& initiator, const Anchor& anchor,
               int64_t phase_us, std::mt19937_64 rng, double offset_m)
      : PeriodicSource(period_us(rate_hz), phase_us),
        p_(p),
        offset_m_(offset_m),
        dt_s_(1.0 / rate_hz),
        initiator_id_(initiator.id),
        initiator_position_(initiator.position),
        anchor_(anchor),
        rng_(std::move(rng)) {}

 protected:
  bool emit(utime_t t, double t_s, SimEvent& ev) override {
    const Eigen::Vector3d from = walker_ ? walker_->path.at(t_s).position : initiator_position_;
    const double true_range = (from - anchor_.position).norm();
    // Draw every random number whether or not the range survives, so the stream stays aligned.
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    std::normal_distribution<double> gauss(0.0, 1.0);
    const double u_loss = uni(rng_);
    const double u_nlos = uni(rng_);
    const double u_bias = uni(rng_);
    const double noise = gauss(rng_);
    const int32_t seq = seq_++;
    const double draw_bias = p_.nlos_bias_min_m + u_bias * (p_.nlos_bias_max_m - p_.nlos_bias_min_m);
    if (p_.nlos_episode_s > 0) {
      // Leave an episode with probability dt/T; enter with the rate that keeps the NLOS share
      // at nlos_probability (balance: P(in) * p_exit = P(out) * p_enter).
      const double p_exit = std::min(1.0, dt_s_ / p_.nlos_episode_s);
      const double p_enter =
          p_.nlos_probability >= 1 ? 1.0
                                   : std::min(1.0, p_exit * p_.nlos_probability / (1 - p_.nlos_probability));
      if (in_nlos_ ? u_nlos < p_exit : u_nlos < p_enter) {
        in_nlos_ = !in_nlos_;
        episode_bias_m_ = draw_bias;
      }
    } else {
      in_nlos_ = u_nlos < p_.nlos_probability;
      episode_bias_m_ = draw_bias;
    }
    if (u_loss < p_.loss_probability || true_range > p_.max_range_m) return false;
    double r = true_range + p_.bias_m + offset_m_ + p_.noise_sigma_m * noise;
    if (in_nlos_) r += episode_bias_m_;
    uwb_range_t m;
    m.utime = t;
    m.source = kSimSource;
    m.tag_id = initiator_id_;
    m.anchor_id = anchor_.id;
    m.range_m = std::max(0.0, r);
    m.rx_power_dbm = m.fp_power_dbm = m.quality = std::numeric_limits<float>::quiet_NaN();
    m.seq = seq;
    encode_event(m, t, "UWB_RANGE", ev);
    return true;
  }

 private:
  UwbTwrParams p_;
  double offset_m_;  // this pair's constant offset (pair offset + both devices' delays)
  double dt_s_;
  bool in_nlos_ = false;
  double episode_bias_m_ = 0;
  std::string initiator_id_;
  const TagTrajectory* walker_ = nullptr;  // nullptr: the initiator is an anchor
  Eigen::Vector3d initiator_position_ = Eigen::Vector3d::Zero();
  const Anchor& anchor_;
  std::mt19937_64 rng_;
  int32_t seq_ = 0;
};

SourceList make(const YamlField& f, const SimWorld& world) {
  f.check_keys({"enabled", "rate_hz", "noise_sigma_m", "bias_m", "nlos_probability",
                "nlos_bias_min_m", "nlos_bias_max_m", "loss_probability", "max_range_m",
                "nlos_episode_s", "anchor_rates_hz", "anchor_pairs_rate_hz",
                "pair_offset_min_m", "pair_offset_max_m", "device_delay_min_m",
                "device_delay_max_m"});
  UwbTwrParams p;
  p.rate_hz = param_in_range(f, "rate_hz", p.rate_hz, 0.01, 1000);
  p.noise_sigma_m = param_in_range(f, "noise_sigma_m", p.noise_sigma_m, 0, 100);
  p.bias_m = param_in_range(f, "bias_m", p.bias_m, -100, 100);
  p.nlos_probability = param_in_range(f, "nlos_probability", p.nlos_probability, 0, 1);
  p.nlos_bias_min_m = param_in_range(f, "nlos_bias_min_m", p.nlos_bias_min_m, 0, 100);
  p.nlos_bias_max_m = param_in_range(f, "nlos_bias_max_m", p.nlos_bias_max_m, p.nlos_bias_min_m, 100);
  p.loss_probability = param_in_range(f, "loss_probability", p.loss_probability, 0, 1);
  p.max_range_m = param_in_range(f, "max_range_m", p.max_range_m, 0, 1e6);
  p.nlos_episode_s = param_in_range(f, "nlos_episode_s", p.nlos_episode_s, 0, 3600);
  p.pair_offset_min_m = param_in_range(f, "pair_offset_min_m", p.pair_offset_min_m, -10, 10);
  p.pair_offset_max_m =
      param_in_range(f, "pair_offset_max_m", p.pair_offset_min_m, p.pair_offset_min_m, 10);
  p.device_delay_min_m = param_in_range(f, "device_delay_min_m", p.device_delay_min_m, -10, 10);
  p.device_delay_max_m =
      param_in_range(f, "device_delay_max_m", p.device_delay_min_m, p.device_delay_min_m, 10);
  p.anchor_pairs_rate_hz = f.get_double("anchor_pairs_rate_hz", p.anchor_pairs_rate_hz);
  if (!(p.anchor_pairs_rate_hz == 0 ||
        (p.anchor_pairs_rate_hz >= 0.01 && p.anchor_pairs_rate_hz <= 1000)))
    f["anchor_pairs_rate_hz"].fail("must be 0 (off) or in [0.01, 1000]");
  // Per-anchor rates: {A1: 5, A3: 20}; other anchors range at rate_hz.
  const YamlField rates = f["anchor_rates_hz"];
  if (rates.defined() && !rates.is_map()) rates.fail("expected a map of anchor id to rate in Hz");
  if (rates.is_map())
    for (const auto& kv : rates.node()) {
      const std::string id = kv.first.Scalar();
      const Anchor* a = world.site.find_anchor(id);
      if (!a || a->kind != "uwb") rates[id].fail("no uwb anchor '" + id + "' in the site");
      param_in_range(rates, id.c_str(), p.rate_hz, 0.01, 1000);
    }

  std::vector<const Anchor*> anchors;
  for (const auto& a : world.site.anchors)
    if (a.kind == "uwb" && a.enabled) anchors.push_back(&a);
  const int64_t period = period_us(p.rate_hz);
  const int64_t slots = std::max<int64_t>(1, static_cast<int64_t>(anchors.size() * world.walkers.size()));
  int64_t slot = 0;
  // The constant offset of a pair: its own, plus both ends' delays.
  auto offset = [&](const std::string& initiator, const std::string& responder) {
    return uwb_pair_offset_m(world.seed, initiator, responder, p.pair_offset_min_m,
                             p.pair_offset_max_m) +
           uwb_device_delay_m(world.seed, initiator, p.device_delay_min_m, p.device_delay_max_m) +
           uwb_device_delay_m(world.seed, responder, p.device_delay_min_m, p.device_delay_max_m);
  };
  SourceList out;
  for (const auto& w : world.walkers)
    for (const Anchor* a : anchors)
      out.push_back(std::make_unique<UwbTwrSource>(
          p, rates.get_double(a->id, p.rate_hz), w, *a, (slot++ * period) / slots + 1000,
          stream_rng(world.seed, "UWB_RANGE " + w.tag_id + " " + a->id), offset(w.tag_id, a->id)));
  // Anchor pairs after every tag source, each in its own slot of the pair period (offset by half
  // a millisecond from the tag slots' 1 ms so that the two schedules rarely coincide).
  if (p.anchor_pairs_rate_hz > 0) {
    const int64_t pair_period = period_us(p.anchor_pairs_rate_hz);
    const int64_t pairs =
        std::max<int64_t>(1, static_cast<int64_t>(anchors.size() * (anchors.size() - 1) / 2));
    int64_t pair_slot = 0;
    for (size_t i = 0; i < anchors.size(); ++i)
      for (size_t j = i + 1; j < anchors.size(); ++j)
        out.push_back(std::make_unique<UwbTwrSource>(
            p, p.anchor_pairs_rate_hz, *anchors[i], *anchors[j],
            (pair_slot++ * pair_period) / pairs + 1500,
            stream_rng(world.seed, "UWB_RANGE_PAIR " + anchors[i]->id + " " + anchors[j]->id),
            offset(anchors[i]->id, anchors[j]->id)));
  }
  return out;
}

}  // namespace

SensorModel uwb_twr_sensor_model() { return {"uwb_twr", &make}; }

double uwb_pair_offset_m(uint64_t seed, const std::string& initiator, const std::string& anchor,
                         double min_m, double max_m) {
  if (min_m == 0 && max_m == 0) return 0.0;
  std::mt19937_64 rng = stream_rng(seed, "UWB_RANGE_OFFSET " + initiator + " " + anchor);
  return std::uniform_real_distribution<double>(min_m, max_m)(rng);
}

double uwb_device_delay_m(uint64_t seed, const std::string& device, double min_m, double max_m) {
  if (min_m == 0 && max_m == 0) return 0.0;
  std::mt19937_64 rng = stream_rng(seed, "UWB_DEVICE_DELAY " + device);
  return std::uniform_real_distribution<double>(min_m, max_m)(rng);
}

}  // namespace ips::sim
