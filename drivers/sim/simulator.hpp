#pragma once
// Turns a scenario into a time-ordered stream of encoded messages (SITE, TRUTH and every enabled
// sensor model's). Pure: no clock, no I/O. The same scenario, seed and start time give the same
// bytes.
#include <cstdint>
#include <functional>
#include <queue>
#include <string>
#include <vector>

#include "core/time.hpp"
#include "drivers/sim/scenario.hpp"
#include "drivers/sim/sensor_model.hpp"

namespace ips::sim {

class Simulator {
 public:
  Simulator(Scenario scenario, uint64_t seed, utime_t start_utime);
  // Sources refer into the scenario held here: not copyable, not movable.
  Simulator(const Simulator&) = delete;
  Simulator& operator=(const Simulator&) = delete;

  // The next event in time order; false once the scenario's duration is over.
  bool next(SimEvent& ev);
  const Scenario& scenario() const { return sc_; }
  utime_t start_utime() const { return start_; }
  utime_t end_utime() const { return end_; }

 private:
  Scenario sc_;
  utime_t start_;
  utime_t end_;
  SourceList sources_;  // SITE first, then the models' in registry order: ties go to the first
  // (next event time, source index), earliest first.
  std::priority_queue<std::pair<int64_t, size_t>, std::vector<std::pair<int64_t, size_t>>,
                      std::greater<>>
      queue_;
};

}  // namespace ips::sim
