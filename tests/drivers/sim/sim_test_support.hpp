#pragma once
// Shared by the simulator tests: run a scenario and decode the messages of one kind.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "drivers/sim/simulator.hpp"

namespace ips::sim {

inline constexpr utime_t kTestStart = 1767225600000000;  // 2026-01-01T00:00:00Z

// Every encoded event of `kind` the scenario produces for `seed` (for byte comparisons).
inline std::vector<SimEvent> simulated_events(const Scenario& sc, uint64_t seed,
                                              const std::string& kind) {
  Simulator sim(sc, seed, kTestStart);
  std::vector<SimEvent> out;
  SimEvent e;
  while (sim.next(e))
    if (e.kind == kind) out.push_back(e);
  return out;
}

// Every message of `kind` (e.g. "BARO") the scenario produces for `seed`, decoded; a message that
// does not decode to exactly its own length fails the test.
template <class Msg>
std::vector<Msg> simulated_messages(const Scenario& sc, uint64_t seed, const std::string& kind) {
  Simulator sim(sc, seed, kTestStart);
  std::vector<Msg> out;
  SimEvent e;
  while (sim.next(e)) {
    if (e.kind != kind) continue;
    Msg m;
    EXPECT_EQ(m.decode(e.data.data(), 0, static_cast<int>(e.data.size())),
              static_cast<int>(e.data.size()));
    out.push_back(m);
  }
  return out;
}

}  // namespace ips::sim
