// libFuzzer target: scenario files given to ips-sim --scenario FILE. A scenario that parses is
// also simulated for a moment, so odd but valid numbers are exercised too.
#include <cstddef>
#include <cstdint>
#include <string>

#include "drivers/sim/simulator.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    ips::sim::Scenario sc = ips::sim::parse_scenario_text(text, "fuzz.yaml");
    sc.duration_s = std::min(sc.duration_s, 0.5);
    ips::sim::Simulator sim(sc, 1, 1767225600000000);
    ips::sim::SimEvent ev;
    for (int i = 0; i < 2000 && sim.next(ev); ++i) {
    }
  } catch (const ips::ConfigError&) {
  }
  return 0;
}
