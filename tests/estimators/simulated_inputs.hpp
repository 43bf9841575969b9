#pragma once
// The estimator tests' in-process loop: a scenario through the simulator, each message of the
// kinds a test asks for decoded and handed to its handler (SITE, TRUTH, UWB_RANGE, UWB_RX, UWB_TDOA,
// BLE_AOA, IMU, BARO, INS_MODULE).
#include <gtest/gtest.h>

#include <functional>
#include <initializer_list>
#include <utility>
#include <ips/baro_t.hpp>
#include <ips/ble_aoa_t.hpp>
#include <ips/imu_t.hpp>
#include <ips/pose_t.hpp>
#include <ips/site_t.hpp>
#include <ips/uwb_range_t.hpp>
#include <ips/uwb_rx_t.hpp>
#include <ips/uwb_tdoa_t.hpp>

#include "core/site.hpp"
#include "drivers/sim/simulator.hpp"

namespace ips::test {

inline constexpr utime_t kSimStart = 1767225600000000;  // 2026-01-01T00:00:00Z

struct SimHandlers {
  std::function<void(const site_t&)> site = nullptr;
  std::function<void(const pose_t&)> truth = nullptr;
  std::function<void(const uwb_range_t&)> uwb_range = nullptr;
  std::function<void(const uwb_rx_t&)> uwb_rx = nullptr;
  std::function<void(const uwb_tdoa_t&)> uwb_tdoa = nullptr;
  std::function<void(const ble_aoa_t&)> ble_aoa = nullptr;
  std::function<void(const imu_t&)> imu = nullptr;
  std::function<void(const baro_t&)> baro = nullptr;
  std::function<void(const pose_t&)> ins_module = nullptr;
};

template <class Msg>
void hand_over(const sim::SimEvent& e, const std::function<void(const Msg&)>& handler) {
  if (!handler) return;
  Msg m;
  if (m.decode(e.data.data(), 0, static_cast<int>(e.data.size())) !=
      static_cast<int>(e.data.size())) {
    ADD_FAILURE() << "a simulated " << e.kind << " does not decode";
    return;
  }
  handler(m);
}

inline void run_simulated(const sim::Scenario& sc, uint64_t seed, const SimHandlers& h) {
  sim::Simulator simulator(sc, seed, kSimStart);
  sim::SimEvent e;
  while (simulator.next(e)) {
    if (e.kind == "SITE") hand_over(e, h.site);
    else if (e.kind == "TRUTH") hand_over(e, h.truth);
    else if (e.kind == "UWB_RANGE") hand_over(e, h.uwb_range);
    else if (e.kind == "UWB_RX") hand_over(e, h.uwb_rx);
    else if (e.kind == "UWB_TDOA") hand_over(e, h.uwb_tdoa);
    else if (e.kind == "BLE_AOA") hand_over(e, h.ble_aoa);
    else if (e.kind == "IMU") hand_over(e, h.imu);
    else if (e.kind == "BARO") hand_over(e, h.baro);
    else if (e.kind == "INS_MODULE") hand_over(e, h.ins_module);
  }
}

// The simulator's site with estimator parameters set: estimators.<estimator>.<key> = value, each
// value YAML ("0.01", "false"); a deliberately wrong noise setting, say.
inline Site site_with_settings(
    const site_t& m, const std::string& estimator,
    std::initializer_list<std::pair<std::string, std::string>> settings) {
  YAML::Node root = YAML::Load(m.site_yaml);
  for (const auto& [key, value] : settings) root["estimators"][estimator][key] = YAML::Load(value);
  return parse_site_text(YAML::Dump(root), "test site");
}

}  // namespace ips::test
