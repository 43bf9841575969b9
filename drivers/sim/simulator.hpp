#pragma once
// Turns a scenario into a time-ordered stream of encoded messages (SITE, TRUTH, UWB_RANGE, ...).
// Pure: no clock, no I/O. The same scenario, seed and start time give the same bytes.
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "core/time.hpp"
#include "drivers/sim/scenario.hpp"

namespace ips::sim {

struct SimEvent {
  utime_t utime = 0;
  std::string kind;            // default channel name, e.g. "UWB_RANGE"
  std::vector<uint8_t> data;   // LCM-encoded message
};

class Simulator {
 public:
  Simulator(Scenario scenario, uint64_t seed, utime_t start_utime);
  // The next event in time order; false once the scenario's duration is over.
  bool next(SimEvent& ev);
  const Scenario& scenario() const { return sc_; }
  utime_t start_utime() const { return start_; }
  utime_t end_utime() const { return end_; }

 private:
  enum class Kind { kSite, kTruth, kUwbRange };
  struct Source {
    Kind kind;
    size_t traj = 0;    // index into scenario trajectories
    size_t anchor = 0;  // index into site anchors
    int64_t period_us;
    int64_t phase_us;
    int64_t count = 0;
    std::mt19937_64 rng;
    int64_t next_us() const { return phase_us + count * period_us; }
  };
  void emit_site(utime_t t, SimEvent& ev);
  void emit_truth(Source& s, utime_t t, SimEvent& ev);
  bool emit_range(Source& s, utime_t t, SimEvent& ev);  // false when the range is lost

  Scenario sc_;
  utime_t start_;
  utime_t end_;
  std::vector<Source> sources_;
  std::vector<int32_t> range_seq_;  // per trajectory
};

}  // namespace ips::sim
