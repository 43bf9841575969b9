#pragma once
// Noise-free TDoA reports built by hand for the unit tests: anchors with clocks
// reading(t) = t + offset0 + rate * t (t true time since the start), counters
// round(63.8976e9 * reading) mod 2^40, a sync from the master every 2 s (its own transmit record,
// then every other anchor's reception after the time of flight) and tag blinks every 100 ms from
// 1 ms after each sync slot. The only error is the counter's rounding, +-0.5 tick (+-2.3 mm of
// range). Hooks drop or alter single reports.
#include <Eigen/Core>
#include <cmath>
#include <functional>
#include <ips/uwb_rx_t.hpp>
#include <string>
#include <vector>

#include "core/site.hpp"
#include "estimators/uwb_tdoa/counter_wrap.hpp"

namespace ips::uwb_tdoa::test {

inline constexpr utime_t kStart = 1767225600000000;
inline constexpr double kHz = 63.8976e9;
inline constexpr double kLatencyS = 0.002;

struct TestAnchor {
  std::string id;
  Eigen::Vector3d position;
  double offset0_s = 0;  // counter reading at t = 0, seconds (any value: reduced mod the wrap)
  double rate_ppb = 0;
};

class ExactNetwork {
 public:
  using Sink = std::function<void(const uwb_rx_t&)>;
  // Return false to drop anchor `i`'s report of sync/blink `seq`.
  using Keep = std::function<bool(int anchor, int32_t seq)>;
  // Return the counter to report instead of `counter`.
  using Alter = std::function<int64_t(int anchor, int32_t seq, int64_t counter)>;

  ExactNetwork(std::vector<TestAnchor> anchors, int master)
      : anchors_(std::move(anchors)), master_(master) {}

  const std::vector<TestAnchor>& anchors() const { return anchors_; }
  int master() const { return master_; }

  // Anchor i's clock reading at true time t, in seconds (not wrapped).
  double reading_s(int i, double t) const {
    const TestAnchor& a = anchors_[i];
    return t + a.offset0_s + a.rate_ppb * 1e-9 * t;
  }
  int64_t counter(int i, double t) const {
    const double ticks = std::round(reading_s(i, t) * kHz);
    return counter_mod(static_cast<int64_t>(ticks));
  }
  // True offset of anchor i from the master at t (s, not wrapped) and rate relative to it (ppb).
  double true_offset_s(int i, double t) const { return reading_s(i, t) - reading_s(master_, t); }
  double true_rate_ppb(int i) const {
    return ((1 + anchors_[i].rate_ppb * 1e-9) / (1 + anchors_[master_].rate_ppb * 1e-9) - 1) * 1e9;
  }

  static uwb_rx_t report(utime_t utime, const std::string& anchor, const std::string& sender,
                         bool is_sync, int32_t seq, int64_t counter) {
    uwb_rx_t m;
    m.utime = utime;
    m.source = "test";
    m.anchor_id = anchor;
    m.sender_id = sender;
    m.is_sync = is_sync;
    m.seq = seq;
    m.rx_counter = counter;
    m.counter_hz = kHz;
    m.rx_power_dbm = m.fp_power_dbm = m.quality = NAN;
    return m;
  }

  // Sync `seq`, sent at true time 2 * seq: the master's record, then the others' receptions.
  void sync(const Sink& sink, int32_t seq, const Keep& keep = nullptr,
            const Alter& alter = nullptr) const {
    const double t = 2.0 * seq;
    const utime_t u = kStart + s_to_utime(t + kLatencyS);
    const std::string& m = anchors_[master_].id;
    sink(report(u, m, m, true, seq, counter(master_, t)));
    for (int i = 0; i < static_cast<int>(anchors_.size()); ++i) {
      if (i == master_ || (keep && !keep(i, seq))) continue;
      const double tof =
          (anchors_[i].position - anchors_[master_].position).norm() / kSpeedOfLightMps;
      int64_t c = counter(i, t + tof);
      if (alter) c = alter(i, seq, c);
      sink(report(u, anchors_[i].id, m, true, seq, c));
    }
  }

  // Blink `seq` of `tag` at true time t from position p.
  void blink(const Sink& sink, const std::string& tag, int32_t seq, double t,
             const Eigen::Vector3d& p, const Keep& keep = nullptr) const {
    const utime_t u = kStart + s_to_utime(t + kLatencyS);
    for (int i = 0; i < static_cast<int>(anchors_.size()); ++i) {
      if (keep && !keep(i, seq)) continue;
      const double tof = (p - anchors_[i].position).norm() / kSpeedOfLightMps;
      sink(report(u, anchors_[i].id, tag, false, seq, counter(i, t + tof)));
    }
  }

  // From true time 0 to `end_s`: syncs every 2 s, blinks of T1 at 10 Hz from 1 ms after each
  // sync, the tag at path(t).
  void run(const Sink& sink, double end_s, const std::function<Eigen::Vector3d(double)>& path,
           const Keep& keep_sync = nullptr, const Keep& keep_blink = nullptr,
           const Alter& alter_sync = nullptr, const std::string& tag = "T1") const {
    for (int32_t k = 0; 0.1 * k < end_s; ++k) {
      if (k % 20 == 0) sync(sink, k / 20, keep_sync, alter_sync);
      const double t = 0.1 * k + 0.001;
      blink(sink, tag, k, t, path(t), keep_blink);
    }
  }

  // A site with these anchors (uwb_tdoa), tag T1 at `height` (NaN: not in the site's tags) and
  // `params` as estimators.uwb_tdoa (a YAML flow map, or empty).
  Site site(double height = 1.2, const std::string& params = "",
            const std::string& extra_anchors = "") const {
    std::string y = "name: exact\nanchors:\n";
    char line[256];
    for (const auto& a : anchors_) {
      std::snprintf(line, sizeof line,
                    "  - {id: %s, kind: uwb_tdoa, position: [%.17g, %.17g, %.17g]}\n", a.id.c_str(),
                    a.position.x(), a.position.y(), a.position.z());
      y += line;
    }
    y += extra_anchors;
    if (!std::isnan(height)) {
      std::snprintf(line, sizeof line, "tags:\n  - {id: T1, height_m: %.17g}\n", height);
      y += line;
    }
    if (!params.empty()) y += "estimators:\n  uwb_tdoa: " + params + "\n";
    return parse_site_text(y, "site.yaml");
  }

 private:
  std::vector<TestAnchor> anchors_;
  int master_;
};

// Five anchors round a 10 x 8 m room at 2.5 m (A1 the master), clocks with offsets spread over
// the whole wrap and rates of tens of ppb (004 §3: 90 ppb between anchors).
inline ExactNetwork room_network() {
  return ExactNetwork({{"A1", {0.0, 0.0, 2.5}, 3.982187, 12.0},
                       {"A2", {10.0, 0.0, 2.5}, 6.525657, -31.0},
                       {"A3", {10.0, 8.0, 2.5}, 16.9, 44.0},
                       {"A4", {0.0, 8.0, 2.5}, 0.25, -7.5},
                       {"A5", {5.0, 4.2, 2.9}, 11.0, 25.0}},
                      0);
}

}  // namespace ips::uwb_tdoa::test
