// UWB TDoA as Loco-style systems deliver it (UWB_TDOA, uwb_tdoa_t): the anchors' clocks are
// synchronised upstream and the tag reports one range difference per anchor packet (Bitcraze
// LPS TDoA2: the anchors transmit in turn and each packet gives the difference to the previous
// anchor's; TDoA3: any two anchors heard). No raw reception, no clock: the physics is
// diff_m = |p - b| - |p - a| + noise (+ NLOS biases).
//
// - pairing `consecutive` (TDoA2): event k is the pair (anchors[k mod n], anchors[k+1 mod n]) in
//   site order; `random` (TDoA3): two different anchors drawn uniformly.
// - noise_sigma_m: Gaussian noise of a difference (0.05 m: LOS Loco figures).
// - nlos_bias_m: {ANCHOR: b}: that anchor's apparent distance is off by b (an obstructed path),
//   so its pairs carry +b as anchor_b and -b as anchor_a (UTIL reports NLOS biases of -0.2 to
//   -3.9 m on the differences). nlos_probability: each difference independently gets a uniform
//   bias in [nlos_bias_min_m, nlos_bias_max_m] (default -3.9 .. -0.2 m).
// - max_range_m: a pair with an anchor farther than this is not heard; loss_probability.
// - report_sigma: true puts noise_sigma_m in sigma_m; false (default) leaves it NaN, as a
//   Crazyflie log does.
// Each walker draws from its own stream ("UWB_TDOA <tag>"), every value drawn whether or not the
// difference is lost, so loss changes no other difference.
#include <algorithm>
#include <cmath>
#include <ips/uwb_tdoa_t.hpp>
#include <limits>
#include <map>

#include "drivers/sim/sensor_model.hpp"

namespace ips::sim {

namespace {

constexpr const char* kUwbTdoaChannel = "UWB_TDOA";  // docs/channels.md

struct PairParams {
  double rate_hz = 100.0;  // differences per second per tag
  bool random_pairs = false;
  double noise_sigma_m = 0.05;
  double nlos_probability = 0.0;
  double nlos_bias_min_m = -3.9;
  double nlos_bias_max_m = -0.2;
  double loss_probability = 0.0;
  double max_range_m = 100.0;
  bool report_sigma = false;
  std::map<std::string, double> anchor_bias_m;
};

class PairSource : public PeriodicSource {
 public:
  PairSource(const PairParams& p, std::vector<const Anchor*> anchors, const TagTrajectory& walker,
             int64_t phase_us, std::mt19937_64 rng)
      : PeriodicSource(period_us(p.rate_hz), phase_us),
        p_(p),
        anchors_(std::move(anchors)),
        walker_(walker),
        rng_(std::move(rng)) {
    for (const Anchor* a : anchors_) {
      auto it = p_.anchor_bias_m.find(a->id);
      bias_.push_back(it == p_.anchor_bias_m.end() ? 0.0 : it->second);
    }
  }

 protected:
  bool emit(utime_t t, double t_s, SimEvent& ev) override {
    const size_t n = anchors_.size();
    const int64_t k = count_++;
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    // Every draw happens on every event, whatever is used.
    const double u_pick_a = uni(rng_), u_pick_b = uni(rng_);
    const double noise = std::normal_distribution<double>(0.0, 1.0)(rng_) * p_.noise_sigma_m;
    const double u_nlos = uni(rng_), u_bias = uni(rng_), u_loss = uni(rng_);
    size_t ia = static_cast<size_t>(k % static_cast<int64_t>(n)), ib = (ia + 1) % n;
    if (p_.random_pairs) {
      ia = std::min(n - 1, static_cast<size_t>(u_pick_a * static_cast<double>(n)));
      ib = std::min(n - 2, static_cast<size_t>(u_pick_b * static_cast<double>(n - 1)));
      if (ib >= ia) ++ib;
    }
    const Eigen::Vector3d p = walker_.path.at(t_s).position;
    const double da = (p - anchors_[ia]->position).norm();
    const double db = (p - anchors_[ib]->position).norm();
    if (da > p_.max_range_m || db > p_.max_range_m || u_loss < p_.loss_probability) return false;
    double diff = db - da + noise + bias_[ib] - bias_[ia];
    if (u_nlos < p_.nlos_probability)
      diff += p_.nlos_bias_min_m + u_bias * (p_.nlos_bias_max_m - p_.nlos_bias_min_m);
    msg_.utime = t;
    msg_.source = kSimSource;
    msg_.tag_id = walker_.tag_id;
    msg_.anchor_a = anchors_[ia]->id;
    msg_.anchor_b = anchors_[ib]->id;
    msg_.diff_m = diff;
    msg_.sigma_m = p_.report_sigma ? static_cast<float>(p_.noise_sigma_m)
                                   : std::numeric_limits<float>::quiet_NaN();
    msg_.quality = std::numeric_limits<float>::quiet_NaN();
    msg_.seq = static_cast<int32_t>(k & 0x7fffffff);
    encode_event(msg_, t, kUwbTdoaChannel, ev);
    return true;
  }

 private:
  PairParams p_;
  std::vector<const Anchor*> anchors_;
  std::vector<double> bias_;
  const TagTrajectory& walker_;
  std::mt19937_64 rng_;
  int64_t count_ = 0;
  uwb_tdoa_t msg_;
};

SourceList make(const YamlField& f, const SimWorld& world) {
  f.check_keys({"enabled", "rate_hz", "pairing", "noise_sigma_m", "nlos_bias_m",
                "nlos_probability", "nlos_bias_min_m", "nlos_bias_max_m", "loss_probability",
                "max_range_m", "report_sigma"});
  PairParams p;
  p.rate_hz = param_in_range(f, "rate_hz", p.rate_hz, 0.01, 10000);
  const std::string pairing = f.get_string("pairing", "consecutive");
  if (pairing != "consecutive" && pairing != "random")
    f["pairing"].fail("expected consecutive (TDoA2) or random (TDoA3)");
  p.random_pairs = pairing == "random";
  p.noise_sigma_m = param_in_range(f, "noise_sigma_m", p.noise_sigma_m, 0, 100);
  p.nlos_probability = param_in_range(f, "nlos_probability", p.nlos_probability, 0, 1);
  p.nlos_bias_min_m = param_in_range(f, "nlos_bias_min_m", p.nlos_bias_min_m, -100, 100);
  p.nlos_bias_max_m = param_in_range(f, "nlos_bias_max_m", p.nlos_bias_max_m, -100, 100);
  if (p.nlos_bias_max_m < p.nlos_bias_min_m)
    f["nlos_bias_max_m"].fail("must not be below nlos_bias_min_m");
  p.loss_probability = param_in_range(f, "loss_probability", p.loss_probability, 0, 1);
  p.max_range_m = param_in_range(f, "max_range_m", p.max_range_m, 0, 1e6);
  p.report_sigma = f.get_bool("report_sigma", p.report_sigma);

  std::vector<const Anchor*> anchors;
  for (const auto& a : world.site.anchors)
    if (a.kind == "uwb_tdoa" && a.enabled) anchors.push_back(&a);
  if (anchors.size() < 2) f.fail("needs at least 2 enabled uwb_tdoa anchors in site.anchors");

  const YamlField biases = f["nlos_bias_m"];
  if (biases.defined()) {
    if (!biases.is_map()) biases.fail("expected a map: anchor id -> bias in m");
    for (const auto& kv : biases.node()) {
      const std::string id = kv.first.IsScalar() ? kv.first.Scalar() : "?";
      if (std::none_of(anchors.begin(), anchors.end(),
                       [&](const Anchor* a) { return a->id == id; }))
        biases[id].fail("'" + id + "' is not an enabled uwb_tdoa anchor of the site");
      p.anchor_bias_m[id] = param_in_range(biases, id.c_str(), 0, -100, 100);
    }
  }

  SourceList out;
  const int64_t period = period_us(p.rate_hz);
  const auto n = static_cast<int64_t>(std::max<size_t>(1, world.walkers.size()));
  int64_t k = 0;
  for (const auto& w : world.walkers)
    out.push_back(std::make_unique<PairSource>(p, anchors, w, 1000 + (k++ * period) / n,
                                               stream_rng(world.seed, std::string(kUwbTdoaChannel) +
                                                                          " " + w.tag_id)));
  return out;
}

}  // namespace

SensorModel uwb_tdoa_pairs_sensor_model() { return {"uwb_tdoa_pairs", &make}; }

}  // namespace ips::sim
