#pragma once
// Ground truth of the simulated TDoA anchor clocks (drivers/sim/models/uwb_tdoa.cpp), for
// estimator tests: a deterministic function of the `uwb_tdoa` section, the site and the seed.
#include <string>

#include "drivers/sim/sensor_model.hpp"

namespace ips::sim {

// The true state of one anchor's clock at t_s seconds after the scenario start. The anchor's
// counter then reads floor(63.8976e9 * (t_s + offset_s)) mod 2^40 (before reception noise).
struct UwbTdoaClockTruth {
  double offset_s;  // clock reading minus true time (not wrapped)
  double rate_ppb;  // d(offset_s)/dt in parts per billion
};

// Throws ConfigError as the model does for a bad section, and for an anchor_id that is not an
// enabled uwb_tdoa anchor.
UwbTdoaClockTruth uwb_tdoa_clock_truth(const YamlField& section, const SimWorld& world,
                                       const std::string& anchor_id, double t_s);

}  // namespace ips::sim
