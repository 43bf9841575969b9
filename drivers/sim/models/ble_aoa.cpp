// BLE angle of arrival as u-blox XPLR-AOA anchors (C211 / NINA-B411, u-connectLocate) report it
// in +UUDF events, on BLE_AOA (ble_aoa_t). Figures from ../shared/reference/000_ble_aoa.md
// ("[T]" = stated by the source, "[I]" = our assumption).
//
// Angles, in the anchor's own frame (the XPLR-AOA convention of the reference, section 1):
//   - the anchor frame is x = the antenna normal (boresight), y = the anchor's left, z = its up.
//     It is the site frame (x east, y north, z up) turned by the mounting orientation
//     [roll, pitch, yaw]: R = Rz(yaw) * Ry(pitch) * Rx(roll), so yaw is the angle from site +x
//     to the normal, counter-clockwise (the reference's beta), positive pitch tilts the normal
//     down (right hand about the left axis), roll turns the board about its normal;
//   - azimuth theta = atan2(-y, x) of the direction to the tag: 0 on the normal, POSITIVE TO THE
//     ANCHOR'S RIGHT seen from above (clockwise). For a level anchor this is the reference's
//     (3.1)/(7.2): alpha = beta - theta, alpha the site bearing of the anchor->tag line;
//   - elevation phi = atan2(z, hypot(x, y)): 0 in the anchor's x-y plane, positive towards the
//     anchor's up (the reference gives no sign; this is the usual spherical convention [I]);
//   - both within +-90 deg: a tag behind the anchor (x <= 0), or with |theta| or |phi| beyond
//     fov_deg, gives no event.
//
// Error model per advertisement and anchor:
//   - measured azimuth = theta + c2 theta^2 + c3 theta^3 (the chamber's edge compression, cubic
//     fit (6.10) without its constant) + per-anchor bias + Gaussian noise; elevation likewise
//     without the cubic (no elevation fit in the source);
//   - noise sigma grows towards the edge: sigma (1 + edge_noise_gain (gamma / 90 deg)^2), gamma the
//     angle off the normal [I] (the source: errors > 10 deg beyond +-60 deg, < 5 deg only within
//     -45..+55 deg, section 4);
//   - per-anchor constant bias (mounting error; section 6.3 suggests "orientation offsets of a few
//     degrees"), drawn per anchor from N(0, bias_sigma_deg) or given in anchor_bias_deg;
//   - loss: the anchor misses the advertisement (no event, its counter does not move);
//   - multipath: a second, later event for the same advertisement with a wrong direction and a
//     weaker RSSI (section 7.2.1: "extra delayed messages with wrong directions");
//   - reported values are integers in +UUDF: angles rounded to angle_resolution_deg, RSSI to 1 dB,
//     angles clamped to +-90 deg.
// Timing: each tag advertises every advertising_interval_ms (100 ms [T]) plus BLE's random
// advDelay of 0..10 ms, rotating over the advertising channels 37, 38, 39. Every anchor reports
// its angle up to report_latency_max_ms later (epochs skewed by up to 25 ms [T]). Each anchor
// stamps its events with its uptime in ms (booted a random time before the start) and counts
// them (field 10 of +UUDF, "message counter"); these two are shared by all tags' sources.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <ips/ble_aoa_t.hpp>
#include <limits>
#include <memory>
#include <random>
#include <vector>

#include "drivers/sim/sensor_model.hpp"

namespace ips::sim {

namespace {

constexpr double kDeg = M_PI / 180.0;

struct BleAoaParams {
  double advertising_interval_ms = 100.0;  // [T] tag setting
  double advertising_delay_max_ms = 10.0;  // BLE advDelay: 0..10 ms added to every interval
  double report_latency_max_ms = 25.0;     // [T] timestamps in one epoch skewed by up to 25 ms
  double noise_sigma_deg = 5.0;            // [T] vendor: 5 deg mean angle error; EKF R = 5^2
  double edge_noise_gain = 1.0;            // [I] sigma doubles at 90 deg off the normal
  double edge_quadratic_per_deg = 0.0008;  // [T] chamber cubic fit (6.10): + 0.0008 theta^2
  double edge_cubic_per_deg2 = -0.000046;  //                              - 0.000046 theta^3
  double bias_sigma_deg = 0.0;             // per-anchor constant bias, azimuth and elevation
  double fov_deg = 90.0;                   // [T] angles within +-90 deg
  double loss_probability = 0.0;
  double multipath_probability = 0.0;      // per delivered event
  double multipath_offset_min_deg = 10.0;  // |wrong - measured| per angle, uniform in [min, max]
  double multipath_offset_max_deg = 60.0;
  double multipath_delay_max_ms = 25.0;   // after the direct event
  double rssi_1m_dbm = -59.0;             // [I] 0 dBm tag [T] seen at 1 m
  double path_loss_exponent = 2.0;        // [I] log-distance model
  double rssi_sigma_db = 3.0;             // [I]
  double angle_resolution_deg = 1.0;      // [T] +UUDF angles are integers; 0: no rounding
  double uptime_at_start_max_s = 3600.0;  // anchors booted up to this long before the start
};

// The reflected copy is weaker than the direct path by a uniform 3..10 dB [I].
constexpr double kMultipathRssiDropMinDb = 3.0;
constexpr double kMultipathRssiDropMaxDb = 10.0;

// One enabled ble_aoa anchor and its device state, shared by every tag's source: the uptime
// counter and the event counter belong to the anchor, not to a (tag, anchor) pair.
struct AoaAnchor {
  const Anchor* anchor;
  Eigen::Matrix3d site_from_anchor;  // columns: the anchor's normal, left and up in the site frame
  double bias_az_deg;
  double bias_el_deg;
  int64_t boot_us;  // uptime at the scenario start
  int32_t next_seq = 0;
};
using AoaAnchors = std::vector<AoaAnchor>;

// One event waiting to be reported (a tag's advertisement at one anchor).
struct PendingEvent {
  int64_t offset_us;  // since the scenario start
  uint64_t order;     // tie-break: generation order
  size_t anchor;
  float azimuth_deg;
  float elevation_deg;
  float rssi_dbm;
  int16_t channel;
};
struct LaterFirst {
  bool operator()(const PendingEvent& a, const PendingEvent& b) const {
    return a.offset_us != b.offset_us ? a.offset_us > b.offset_us : a.order > b.order;
  }
};

double quantize(double v, double step) { return step > 0 ? step * std::round(v / step) : v; }

// One tag: its advertisements and, for each, the events of every anchor. The events of one
// advertisement are reported later (latency, multipath delay), possibly after the next
// advertisement, so they wait in a small heap; an advertisement is itself a step of the source
// (fire() returns false for it) so that time order holds for any latency.
class BleAoaTagSource : public SensorSource {
 public:
  BleAoaTagSource(const BleAoaParams& p, const TagTrajectory& walker,
                  std::shared_ptr<AoaAnchors> anchors, std::mt19937_64 tag_rng,
                  std::vector<std::mt19937_64> anchor_rngs)
      : p_(p),
        walker_(walker),
        anchors_(std::move(anchors)),
        tag_rng_(std::move(tag_rng)),
        rngs_(std::move(anchor_rngs)),
        interval_us_(s_to_utime(p.advertising_interval_ms * 1e-3)),
        adv_delay_max_us_(p.advertising_delay_max_ms * 1e3) {
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    phase_us_ = static_cast<int64_t>(uni(tag_rng_) * static_cast<double>(interval_us_));
    channel_index_ = static_cast<int>(std::min(2.0, std::floor(uni(tag_rng_) * 3.0)));
    schedule_next_advertisement();
    pending_.reserve(4 * rngs_.size() + 8);
    msg_.source = kSimSource;
    msg_.tag_id = walker_.tag_id;
    msg_.user_string = "";
  }

  int64_t next_us() const override {
    return pending_.empty() ? next_adv_us_ : std::min(next_adv_us_, pending_.front().offset_us);
  }

  bool fire(utime_t start, SimEvent& ev) override {
    if (pending_.empty() || next_adv_us_ <= pending_.front().offset_us) {
      advertise();
      return false;
    }
    std::pop_heap(pending_.begin(), pending_.end(), LaterFirst{});
    const PendingEvent e = pending_.back();
    pending_.pop_back();
    AoaAnchor& a = (*anchors_)[e.anchor];
    const utime_t t = start + e.offset_us;
    msg_.utime = t;
    msg_.anchor_id = a.anchor->id;
    msg_.azimuth_deg = e.azimuth_deg;
    msg_.elevation_deg = e.elevation_deg;
    msg_.rssi_dbm = e.rssi_dbm;
    msg_.channel = e.channel;
    msg_.anchor_uptime_ms = (a.boot_us + e.offset_us) / 1000;
    msg_.seq = a.next_seq;
    a.next_seq = a.next_seq == std::numeric_limits<int32_t>::max() ? 0 : a.next_seq + 1;
    encode_event(msg_, t, "BLE_AOA", ev);
    return true;
  }

 private:
  void schedule_next_advertisement() {
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    next_adv_us_ = phase_us_ + adv_count_ * interval_us_ +
                   static_cast<int64_t>(uni(tag_rng_) * adv_delay_max_us_);
  }

  void push(const PendingEvent& e) {
    pending_.push_back(e);
    std::push_heap(pending_.begin(), pending_.end(), LaterFirst{});
  }

  void advertise() {
    const int64_t t_us = next_adv_us_;
    const Eigen::Vector3d tag = walker_.path.at(utime_to_s(t_us)).position;
    const auto channel = static_cast<int16_t>(37 + channel_index_);
    for (size_t i = 0; i < anchors_->size(); ++i) {
      const AoaAnchor& a = (*anchors_)[i];
      std::mt19937_64& rng = rngs_[i];
      // Every draw happens whatever becomes of the event, so the stream stays aligned.
      std::uniform_real_distribution<double> uni(0.0, 1.0);
      std::normal_distribution<double> gauss(0.0, 1.0);
      const double u_loss = uni(rng);
      const double n_az = gauss(rng);
      const double n_el = gauss(rng);
      const double n_rssi = gauss(rng);
      const double u_latency = uni(rng);
      const double u_multipath = uni(rng);
      const double u_mp_delay = uni(rng);
      const double u_mp_az = uni(rng);
      const double u_mp_el = uni(rng);
      const double u_mp_signs = uni(rng);
      const double u_mp_rssi = uni(rng);

      const Eigen::Vector3d d = tag - a.anchor->position;
      const Eigen::Vector3d b = a.site_from_anchor.transpose() * d;  // in the anchor frame
      const double range = d.norm();
      if (!(b.x() > 0) || u_loss < p_.loss_probability) continue;
      const double az = std::atan2(-b.y(), b.x()) / kDeg;
      const double el = std::atan2(b.z(), std::hypot(b.x(), b.y())) / kDeg;
      if (std::abs(az) > p_.fov_deg || std::abs(el) > p_.fov_deg) continue;

      const double off_normal = std::acos(std::clamp(b.x() / range, -1.0, 1.0)) / kDeg / 90.0;
      const double sigma =
          p_.noise_sigma_deg * (1.0 + p_.edge_noise_gain * off_normal * off_normal);
      const double az_meas = az + p_.edge_quadratic_per_deg * az * az +
                             p_.edge_cubic_per_deg2 * az * az * az + a.bias_az_deg + sigma * n_az;
      const double el_meas = el + a.bias_el_deg + sigma * n_el;
      // Log-distance path loss; below 0.1 m the model means nothing.
      const double rssi = p_.rssi_1m_dbm -
                          10.0 * p_.path_loss_exponent * std::log10(std::max(range, 0.1)) +
                          p_.rssi_sigma_db * n_rssi;
      const int64_t report_us =
          t_us + static_cast<int64_t>(u_latency * p_.report_latency_max_ms * 1e3);
      push({report_us, order_++, i, reported_angle(az_meas), reported_angle(el_meas),
            static_cast<float>(std::round(rssi)), channel});

      if (u_multipath < p_.multipath_probability) {
        const double span = p_.multipath_offset_max_deg - p_.multipath_offset_min_deg;
        // u_mp_signs picks one of four sign pairs for (azimuth, elevation).
        const double s_az = u_mp_signs < 0.5 ? 1.0 : -1.0;
        const double s_el = std::fmod(u_mp_signs * 2.0, 1.0) < 0.5 ? 1.0 : -1.0;
        const double rssi_mp = rssi - kMultipathRssiDropMinDb -
                               u_mp_rssi * (kMultipathRssiDropMaxDb - kMultipathRssiDropMinDb);
        push({report_us + static_cast<int64_t>(u_mp_delay * p_.multipath_delay_max_ms * 1e3),
              order_++, i,
              reported_angle(az_meas + s_az * (p_.multipath_offset_min_deg + u_mp_az * span)),
              reported_angle(el_meas + s_el * (p_.multipath_offset_min_deg + u_mp_el * span)),
              static_cast<float>(std::round(rssi_mp)), channel});
      }
    }
    channel_index_ = (channel_index_ + 1) % 3;
    ++adv_count_;
    schedule_next_advertisement();
  }

  float reported_angle(double deg) const {
    return static_cast<float>(std::clamp(quantize(deg, p_.angle_resolution_deg), -90.0, 90.0));
  }

  BleAoaParams p_;
  const TagTrajectory& walker_;
  std::shared_ptr<AoaAnchors> anchors_;
  std::mt19937_64 tag_rng_;            // advertising phase, channel and advDelay
  std::vector<std::mt19937_64> rngs_;  // one per anchor: this tag's events there
  int64_t interval_us_;
  double adv_delay_max_us_;
  int64_t phase_us_ = 0;
  int64_t adv_count_ = 0;
  int64_t next_adv_us_ = 0;
  int channel_index_ = 0;
  uint64_t order_ = 0;
  std::vector<PendingEvent> pending_;  // a min-heap by (offset_us, order)
  ble_aoa_t msg_;
};

SourceList make(const YamlField& f, const SimWorld& world) {
  f.check_keys({"enabled",
                "advertising_interval_ms",
                "advertising_delay_max_ms",
                "report_latency_max_ms",
                "noise_sigma_deg",
                "edge_noise_gain",
                "edge_quadratic_per_deg",
                "edge_cubic_per_deg2",
                "bias_sigma_deg",
                "anchor_bias_deg",
                "fov_deg",
                "loss_probability",
                "multipath_probability",
                "multipath_offset_min_deg",
                "multipath_offset_max_deg",
                "multipath_delay_max_ms",
                "rssi_1m_dbm",
                "path_loss_exponent",
                "rssi_sigma_db",
                "angle_resolution_deg",
                "uptime_at_start_max_s"});
  BleAoaParams p;
  p.advertising_interval_ms =
      param_in_range(f, "advertising_interval_ms", p.advertising_interval_ms, 20, 10240);
  p.advertising_delay_max_ms =
      param_in_range(f, "advertising_delay_max_ms", p.advertising_delay_max_ms, 0, 10);
  p.report_latency_max_ms =
      param_in_range(f, "report_latency_max_ms", p.report_latency_max_ms, 0, 10000);
  p.noise_sigma_deg = param_in_range(f, "noise_sigma_deg", p.noise_sigma_deg, 0, 90);
  p.edge_noise_gain = param_in_range(f, "edge_noise_gain", p.edge_noise_gain, 0, 100);
  p.edge_quadratic_per_deg =
      param_in_range(f, "edge_quadratic_per_deg", p.edge_quadratic_per_deg, -0.01, 0.01);
  p.edge_cubic_per_deg2 =
      param_in_range(f, "edge_cubic_per_deg2", p.edge_cubic_per_deg2, -0.001, 0.001);
  p.bias_sigma_deg = param_in_range(f, "bias_sigma_deg", p.bias_sigma_deg, 0, 90);
  p.fov_deg = param_in_range(f, "fov_deg", p.fov_deg, 1, 90);
  p.loss_probability = param_in_range(f, "loss_probability", p.loss_probability, 0, 1);
  p.multipath_probability =
      param_in_range(f, "multipath_probability", p.multipath_probability, 0, 1);
  p.multipath_offset_min_deg =
      param_in_range(f, "multipath_offset_min_deg", p.multipath_offset_min_deg, 0, 180);
  p.multipath_offset_max_deg =
      param_in_range(f, "multipath_offset_max_deg",
                     std::max(p.multipath_offset_max_deg, p.multipath_offset_min_deg),
                     p.multipath_offset_min_deg, 180);
  p.multipath_delay_max_ms =
      param_in_range(f, "multipath_delay_max_ms", p.multipath_delay_max_ms, 0, 10000);
  p.rssi_1m_dbm = param_in_range(f, "rssi_1m_dbm", p.rssi_1m_dbm, -120, 20);
  p.path_loss_exponent = param_in_range(f, "path_loss_exponent", p.path_loss_exponent, 1, 6);
  p.rssi_sigma_db = param_in_range(f, "rssi_sigma_db", p.rssi_sigma_db, 0, 30);
  p.angle_resolution_deg = param_in_range(f, "angle_resolution_deg", p.angle_resolution_deg, 0, 10);
  p.uptime_at_start_max_s =
      param_in_range(f, "uptime_at_start_max_s", p.uptime_at_start_max_s, 0, 4e6);

  // anchor_bias_deg: {ANCHOR_ID: [azimuth, elevation]} overrides the drawn bias of that anchor.
  const YamlField given = f["anchor_bias_deg"];
  if (given.defined() && !given.is_map())
    given.fail("expected a map of anchor id: [azimuth_deg, elevation_deg]");
  if (given.is_map()) {
    for (const auto& kv : given.node()) {
      const std::string id = kv.first.IsScalar() ? kv.first.Scalar() : "?";
      const YamlField entry = given[id];
      const Anchor* a = world.site.find_anchor(id);
      if (!a || a->kind != "ble_aoa") entry.fail("no ble_aoa anchor '" + id + "' in the site");
      const Eigen::Vector2d v = entry.as_vec2();
      if (v.cwiseAbs().maxCoeff() > 90) entry.fail("must be within [-90, 90] deg");
    }
  }

  auto anchors = std::make_shared<AoaAnchors>();
  for (const auto& a : world.site.anchors) {
    if (a.kind != "ble_aoa" || !a.enabled) continue;
    // The anchor's own stream (not a tag's): its bias and boot time are the same for every tag.
    std::mt19937_64 rng = stream_rng(world.seed, "BLE_AOA anchor " + a.id);
    std::normal_distribution<double> gauss(0.0, 1.0);
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    const double bias_az = p.bias_sigma_deg * gauss(rng);
    const double bias_el = p.bias_sigma_deg * gauss(rng);
    const double boot_s = uni(rng) * p.uptime_at_start_max_s;
    const Eigen::Vector3d& o = a.orientation_rad;  // roll, pitch, yaw
    const Eigen::Matrix3d r = (Eigen::AngleAxisd(o.z(), Eigen::Vector3d::UnitZ()) *
                               Eigen::AngleAxisd(o.y(), Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(o.x(), Eigen::Vector3d::UnitX()))
                                  .toRotationMatrix();
    AoaAnchor s{&a, r, bias_az, bias_el, s_to_utime(boot_s)};
    if (given.is_map() && given[a.id].defined()) {
      const Eigen::Vector2d v = given[a.id].as_vec2();
      s.bias_az_deg = v.x();
      s.bias_el_deg = v.y();
    }
    anchors->push_back(s);
  }

  SourceList out;
  if (anchors->empty()) return out;
  for (const auto& w : world.walkers) {
    std::vector<std::mt19937_64> rngs;
    for (const auto& a : *anchors)
      rngs.push_back(stream_rng(world.seed, "BLE_AOA " + w.tag_id + " " + a.anchor->id));
    out.push_back(std::make_unique<BleAoaTagSource>(
        p, w, anchors, stream_rng(world.seed, "BLE_AOA tag " + w.tag_id), std::move(rngs)));
  }
  return out;
}

}  // namespace

SensorModel ble_aoa_sensor_model() { return {"ble_aoa", &make}; }

}  // namespace ips::sim
