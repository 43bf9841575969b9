// libFuzzer target: arbitrary bytes arriving from the bus. The first byte picks a message type;
// the rest is decoded the way the node runtime decodes it (decode_message). UWB_RANGE bytes are
// then fed as a sequence of length-prefixed messages into the TWR tracker (NaN, inf, huge and
// negative numbers, unknown ids, time going backwards), which must publish only finite positions
// and never crash; UWB_RX bytes likewise into the TDoA estimator (syncs and blinks with any
// counters, ids and times), which must publish only finite positions and clock estimates;
// BLE_AOA, IMU and BARO sequences into the AoA, PDR and altitude estimators; a mixed sequence of
// every input of ips-fuse into the fusion estimator (selector 19 and up; 16 decodes
// uwb_twr_timestamps_t, 17 uwb_tdoa_t; 18 feeds a sequence of uwb_tdoa_t, pairwise TDoA, into the
// TDoA estimator's pair tracker, which must publish only finite positions; 20 a mixed sequence of
// poses, ALTITUDE and HEALTH into ips-zones' monitor, whose events must be in order and finite).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <ips/altitude_t.hpp>
#include <ips/baro_t.hpp>
#include <ips/ble_aoa_t.hpp>
#include <ips/clock_t.hpp>
#include <ips/health_t.hpp>
#include <ips/imu_t.hpp>
#include <ips/pose_t.hpp>
#include <ips/site_t.hpp>
#include <ips/step_t.hpp>
#include <ips/uwb_range_t.hpp>
#include <ips/uwb_twr_timestamps_t.hpp>
#include <ips/uwb_rx_t.hpp>
#include <ips/uwb_tdoa_t.hpp>
#include <stdexcept>

#include "core/node.hpp"
#include "estimators/altitude/altitude_estimator.hpp"
#include "estimators/aoa/aoa_estimator.hpp"
#include "estimators/pdr/pdr_estimator.hpp"
#include "estimators/uwb_tdoa/tdoa_estimator.hpp"
#include "estimators/uwb_twr/twr_estimator.hpp"
#include "estimators/zones/zone_monitor.hpp"
#include "fusion/fuse_estimator.hpp"

namespace {
const ips::Site& lab_site() {
  static const ips::Site site = ips::parse_site_text(
      "name: lab\nanchors:\n"
      "  - {id: A1, position: [0, 0, 2.4]}\n  - {id: A2, position: [10, 0, 2.4]}\n"
      "  - {id: A3, position: [10, 8, 2.4]}\n  - {id: A4, position: [0, 8, 2.4]}\n"
      "tags:\n  - {id: T1, height_m: 1.2}\n  - {id: T3}\n",
      "fuzz-site");
  return site;
}

const ips::Site& tdoa_site() {
  static const ips::Site site = ips::parse_site_text(
      "name: hall\nanchors:\n"
      "  - {id: D1, kind: uwb_tdoa, position: [0.3, 0.3, 2.6]}\n"
      "  - {id: D2, kind: uwb_tdoa, position: [9.7, 0.3, 2.6]}\n"
      "  - {id: D3, kind: uwb_tdoa, position: [9.7, 7.7, 2.6]}\n"
      "  - {id: D4, kind: uwb_tdoa, position: [0.3, 7.7, 2.6]}\n"
      "tags:\n  - {id: T1, height_m: 1.2}\n  - {id: T3}\n",
      "fuzz-tdoa-site");
  return site;
}

// The hall of source 000 with one calibration polynomial, so corrections are exercised too.
const ips::Site& aoa_site() {
  static const ips::Site site = ips::parse_site_text(
      "name: aoa-hall\nanchors:\n"
      "  - {id: A1, kind: ble_aoa, position: [0, 0, 1.683], orientation_deg: [0, 0, 60.73]}\n"
      "  - {id: A2, kind: ble_aoa, position: [4.552, -0.119, 1.627], orientation_deg: [0, 0, 119.27]}\n"
      "  - {id: A3, kind: ble_aoa, position: [-0.105, 8.126, 1.723], orientation_deg: [0, 0, -60.73]}\n"
      "  - {id: A4, kind: ble_aoa, position: [4.651, 8.103, 1.681], orientation_deg: [0, 0, -119.27]}\n"
      "tags:\n  - {id: T1, height_m: 1.528}\n"
      "estimators:\n  aoa:\n    calibration:\n"
      "      A2: {azimuth: {polynomial: [-0.8, 1.02, 0.0008, -0.000046], valid_deg: [-52, 62]}}\n",
      "fuzz-aoa-site");
  return site;
}

// The sequence inputs: [length byte][message bytes]..., each decoded as Msg and handed to
// `on_message` when it decodes.
template <class Msg, class OnMessage>
void for_each_message(const uint8_t* data, size_t size, OnMessage&& on_message) {
  size_t pos = 0;
  while (pos + 1 < size) {
    const size_t len = std::min<size_t>(data[pos], size - pos - 1);
    Msg m;
    if (ips::decode_message(m, data + pos + 1, len)) on_message(m);
    pos += 1 + len;
  }
}

// The mixed sequence inputs: [kind byte][length byte][message bytes]...; `on_message(kind % kinds,
// feed)` where feed(Msg{}, use) decodes the bytes as Msg and hands them to `use` when they decode.
template <class OnMessage>
void for_each_kind_message(const uint8_t* data, size_t size, uint8_t kinds,
                           OnMessage&& on_message) {
  size_t pos = 0;
  while (pos + 2 < size) {
    const uint8_t kind = static_cast<uint8_t>(data[pos] % kinds);
    const size_t len = std::min<size_t>(data[pos + 1], size - pos - 2);
    const uint8_t* m = data + pos + 2;
    pos += 2 + len;
    on_message(kind, [&](auto msg, auto&& use) {
      if (ips::decode_message(msg, m, len)) use(msg);
    });
  }
}

template <class Msg>
void decode_one(const uint8_t* data, size_t size) {
  Msg m;
  if (ips::decode_message(m, data, size)) {
    // A decoded message re-encodes to the same number of bytes it was decoded from.
    if (m.getEncodedSize() > static_cast<int>(size)) throw std::logic_error("size mismatch");
  }
}

void feed_tracker(const uint8_t* data, size_t size) {
  ips::uwb_twr::TwrEstimator est([](const ips::pose_t& p) {
    for (double v : p.position)
      if (!std::isfinite(v)) throw std::logic_error("non-finite position published");
  });
  est.set_site(lab_site());
  for_each_message<ips::uwb_range_t>(data, size, [&](const ips::uwb_range_t& m) { est.on_range(m); });
}

void feed_tdoa(const uint8_t* data, size_t size) {
  ips::uwb_tdoa::TdoaEstimator est(
      [](const ips::pose_t& p) {
        for (double v : p.position)
          if (!std::isfinite(v)) throw std::logic_error("non-finite TDoA position published");
      },
      [](const ips::clock_t& c) {
        if (!std::isfinite(c.offset_s) || !std::isfinite(c.rate_ppb))
          throw std::logic_error("non-finite clock estimate published");
      });
  est.set_site(tdoa_site());
  for_each_message<ips::uwb_rx_t>(data, size, [&](const ips::uwb_rx_t& m) { est.on_rx(m); });
  est.flush();
}

void feed_tdoa_pairs(const uint8_t* data, size_t size) {
  ips::uwb_tdoa::TdoaEstimator est(
      [](const ips::pose_t& p) {
        for (double v : p.position)
          if (!std::isfinite(v)) throw std::logic_error("non-finite pairwise TDoA position");
        for (double v : p.position_cov)
          if (!std::isfinite(v)) throw std::logic_error("non-finite pairwise TDoA covariance");
      },
      [](const ips::clock_t&) {});
  est.set_site(tdoa_site());
  for_each_message<ips::uwb_tdoa_t>(data, size, [&](const ips::uwb_tdoa_t& m) { est.on_pair(m); });
}

// A sequence of ble_aoa_t through the AoA estimator, once as the EKF and once per epoch (LM).
void feed_aoa(const uint8_t* data, size_t size) {
  for (bool ekf : {true, false}) {
    ips::aoa::AoaEstimator est([](const ips::pose_t& p) {
      for (double v : p.position)
        if (!std::isfinite(v)) throw std::logic_error("non-finite AoA position published");
    });
    if (!ekf) est.override_method(ips::aoa::AoaMethod::kPerEpoch);
    est.set_site(aoa_site());
    for_each_message<ips::ble_aoa_t>(data, size, [&](const ips::ble_aoa_t& m) { est.on_event(m); });
    est.finish();
  }
}

// A sequence of imu_t through the PDR estimator (a short alignment so fuzzed inputs reach the
// walking code).
void feed_pdr(const uint8_t* data, size_t size) {
  static const ips::Site site = ips::parse_site_text(
      "name: walk\nanchors: []\ntags:\n"
      "  - {id: P1, height_m: 1.1, start_position: [0, 0], start_heading_deg: 0}\n"
      "estimators:\n  pdr: {init_still_s: 0.1, max_align_s: 0.5}\n",
      "fuzz-pdr-site");
  ips::pdr::PdrEstimator est(
      [](const ips::step_t& s) {
        // A step of unknown heading (a device without a gyroscope) says so: heading_known
        // false and heading_rad NaN (pdr_estimator.hpp); every other step has a finite one.
        if (!std::isfinite(s.length_m) || !(s.length_m > 0) || !std::isfinite(s.cadence_hz) ||
            s.heading_known != std::isfinite(s.heading_rad))
          throw std::logic_error("non-finite step published");
      },
      [](const ips::pose_t& p) {
        for (double v : p.position)
          if (!std::isfinite(v)) throw std::logic_error("non-finite PDR position published");
      });
  est.set_site(site);
  for_each_message<ips::imu_t>(data, size, [&](const ips::imu_t& m) { est.on_imu(m); });
}

// A sequence of baro_t through the altitude estimator (tags and reference stations, any times,
// pressures, temperatures and heights; floors on, so floor detection runs too).
void feed_altitude(const uint8_t* data, size_t size) {
  static const ips::Site site = ips::parse_site_text(
      "name: baro\nanchors: []\nbaro_stations: [{id: B1, position: [0.3, 0.3, 2.4]}]\n"
      "tags: [{id: T1}]\nestimators:\n  altitude: {offsets_pa: {T1: 25.0}, "
      "floors: {heights_m: [0, 3.5]}}\n",
      "fuzz-baro-site");
  ips::altitude::AltitudeEstimator est([](const ips::altitude_t& a) {
    if (!std::isfinite(a.height_m) || !std::isfinite(a.height_std_m) ||
        !std::isfinite(a.vertical_speed_mps))
      throw std::logic_error("non-finite altitude published");
  });
  est.set_site(site);
  for_each_message<ips::baro_t>(data, size, [&](const ips::baro_t& m) { est.on_baro(m); });
  est.finish();
}
// A mixed sequence into ips-fuse: [kind byte][length byte][message bytes]..., the kind picking
// UWB_RANGE, UWB_RX, IMU, INS_MODULE, POSE_INS, STEP, ALTITUDE, POSE_TDOA, POSE_AOA or BLE_AOA.
// The site has TWR, TDoA and AoA anchors and a tag with a start pose, so every path runs from the
// first byte.
void feed_fuse(const uint8_t* data, size_t size) {
  static const ips::Site site = ips::parse_site_text(
      "name: lab\nanchors:\n"
      "  - {id: A1, position: [0, 0, 2.4]}\n  - {id: A2, position: [10, 0, 2.4]}\n"
      "  - {id: A3, position: [10, 8, 2.4]}\n  - {id: A4, position: [0, 8, 2.4]}\n"
      "  - {id: D1, kind: uwb_tdoa, position: [0.3, 0.3, 2.6]}\n"
      "  - {id: D2, kind: uwb_tdoa, position: [9.7, 0.3, 2.6]}\n"
      "  - {id: D3, kind: uwb_tdoa, position: [9.7, 7.7, 2.6]}\n"
      "  - {id: B1, kind: ble_aoa, position: [5, 0, 2.2], orientation_deg: [0, 0, 90]}\n"
      "  - {id: B2, kind: ble_aoa, position: [10, 4, 2.2], orientation_deg: [0, 0, 180]}\n"
      "tags:\n  - {id: T1, height_m: 1.2, start_position: [2, 1.5]}\n  - {id: T3}\n"
      "estimators:\n  fuse: {max_tags: 8}\n",
      "fuzz-fuse-site");
  ips::fusion::FuseEstimator est([](const ips::pose_t& p) {
    for (double v : p.position)
      if (!std::isfinite(v)) throw std::logic_error("non-finite fused position published");
    for (double v : p.position_cov)
      if (!std::isfinite(v)) throw std::logic_error("non-finite fused covariance published");
  });
  est.set_site(site);
  for_each_kind_message(data, size, 10, [&](uint8_t kind, auto&& feed) {
    switch (kind) {
      case 0: feed(ips::uwb_range_t{}, [&](const ips::uwb_range_t& x) { est.on_range(x); }); break;
      case 1: feed(ips::uwb_rx_t{}, [&](const ips::uwb_rx_t& x) { est.on_rx(x); }); break;
      case 2: feed(ips::imu_t{}, [&](const ips::imu_t& x) { est.on_imu(x); }); break;
      case 3: feed(ips::pose_t{}, [&](const ips::pose_t& x) { est.on_ins_module(x); }); break;
      case 4: feed(ips::pose_t{}, [&](const ips::pose_t& x) { est.on_pose_ins(x); }); break;
      case 5: feed(ips::step_t{}, [&](const ips::step_t& x) { est.on_step(x); }); break;
      case 6: feed(ips::altitude_t{}, [&](const ips::altitude_t& x) { est.on_altitude(x); }); break;
      case 7: feed(ips::pose_t{}, [&](const ips::pose_t& x) { est.on_pose(x, "tdoa"); }); break;
      case 8: feed(ips::pose_t{}, [&](const ips::pose_t& x) { est.on_pose(x, "aoa"); }); break;
      default: feed(ips::ble_aoa_t{}, [&](const ips::ble_aoa_t& x) { est.on_aoa(x); }); break;
    }
  });
  est.flush();
}

// A mixed sequence into ips-zones: [kind byte][length byte][message bytes]..., the kind picking
// a pose, an ALTITUDE or a HEALTH. The site has two floors, a zone on one of them with a dwell,
// and a zone on every floor, so that every path of the hysteresis, floor and alert rules runs.
void feed_zones(const uint8_t* data, size_t size) {
  static const ips::Site site = ips::parse_site_text(
      "name: z\nanchors:\n  - {id: A1, position: [0, 0, 2.4]}\n"
      "tags:\n  - {id: T1}\n  - {id: T2}\n"
      "floors:\n  - {index: 0, height_m: 0}\n  - {index: 1, height_m: 3.5}\n"
      "zones:\n  - {id: a, floor: 0, polygon: [[3, 0.5], [6, 0.5], [6, 2.5], [3, 2.5]], "
      "dwell_s: 1, alert: [enter, dwell]}\n"
      "  - {id: b, polygon: [[0, 3], [2.5, 3], [2.5, 6], [0, 6]], alert: leave, "
      "hysteresis_m: 0}\n"
      "alerts: {tag_silent_s: 2, process_silent_s: 2}\n",
      "fuzz-zones-site");
  int64_t event_seq = 0, alert_seq = 0;
  ips::zones::ZoneMonitor monitor(
      {},
      [&](const ips::zone_event_t& e) {
        if (e.seq != event_seq++) throw std::logic_error("zone event out of sequence");
        if (!std::isfinite(e.dwell_s) || e.dwell_s < 0)
          throw std::logic_error("zone event with a bad dwell_s");
      },
      [&](const ips::alert_t& a) {
        if (a.seq != alert_seq++ || a.id <= 0) throw std::logic_error("alert out of sequence");
        if (a.text.find('\n') != std::string::npos) throw std::logic_error("alert text lines");
      });
  monitor.set_site(site);
  for_each_kind_message(data, size, 3, [&](uint8_t kind, auto&& feed) {
    switch (kind) {
      case 0: feed(ips::pose_t{}, [&](const ips::pose_t& x) { monitor.on_pose(x); }); break;
      case 1:
        feed(ips::altitude_t{}, [&](const ips::altitude_t& x) { monitor.on_altitude(x); });
        break;
      default: feed(ips::health_t{}, [&](const ips::health_t& x) { monitor.on_health(x); }); break;
    }
  });
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const uint8_t* d = data + 1;
  const size_t n = size - 1;
  switch (data[0] % 32) {
    case 0: decode_one<ips::site_t>(d, n); break;
    case 1: decode_one<ips::pose_t>(d, n); break;
    case 2: decode_one<ips::uwb_rx_t>(d, n); break;
    case 3: decode_one<ips::ble_aoa_t>(d, n); break;
    case 4: decode_one<ips::imu_t>(d, n); break;
    case 5: decode_one<ips::baro_t>(d, n); break;
    case 6: decode_one<ips::health_t>(d, n); break;
    case 7: decode_one<ips::step_t>(d, n); break;
    case 8: decode_one<ips::altitude_t>(d, n); break;
    case 9: decode_one<ips::clock_t>(d, n); break;
    case 10: decode_one<ips::uwb_range_t>(d, n); break;
    case 11: feed_tracker(d, n); break;
    case 12: feed_tdoa(d, n); break;
    case 13: feed_aoa(d, n); break;
    case 14: feed_pdr(d, n); break;
    case 15: feed_altitude(d, n); break;
    case 16: decode_one<ips::uwb_twr_timestamps_t>(d, n); break;
    case 17: decode_one<ips::uwb_tdoa_t>(d, n); break;
    case 18: feed_tdoa_pairs(d, n); break;
    case 20: feed_zones(d, n); break;
    default: feed_fuse(d, n); break;
  }
  return 0;
}
