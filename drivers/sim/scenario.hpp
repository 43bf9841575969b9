#pragma once
// A simulator scenario: a site, one trajectory per tag, and sensor error models
// (docs/site-file.md). Built-in scenarios are the files of config/scenarios/, compiled in.
#include <string>
#include <vector>

#include "core/site.hpp"
#include "drivers/sim/sensor_model.hpp"
#include "drivers/sim/trajectory.hpp"

namespace ips::sim {

// One enabled `sensors:` section and the model it belongs to.
struct SensorSection {
  const SensorModel* model;
  YamlField section;
};

struct Scenario {
  std::string name;
  double duration_s = 60.0;
  double site_period_s = 5.0;
  Site site;
  std::vector<TagTrajectory> trajectories;
  std::vector<SensorSection> sensors;  // TRUTH always among them

  // The section of model `name` (e.g. "uwb_twr"), or nullptr when it is not enabled.
  const SensorSection* sensor(const std::string& name) const;
};

// Parses a scenario from YAML text; throws ConfigError naming file, line, field and reason.
Scenario parse_scenario_text(const std::string& text, const std::string& origin);

// Loads NAME (a built-in scenario) or FILE (a path to a scenario file). Throws ConfigError with
// the list of built-in names when NAME is neither.
Scenario load_scenario(const std::string& name_or_file);

// Makes every walker N walkers (--tags N): copies of each tag, named "<tag>-2" ... "<tag>-N" and
// added to the site, walk the same path started later (spread over one lap of a loop, 2 s apart
// otherwise). Throws ConfigError when n is not in [1, 1000].
void replicate_walkers(Scenario& sc, int n);

// Built-in scenario names and their YAML text.
std::vector<std::string> builtin_scenario_names();
const char* builtin_scenario_text(const std::string& name);  // nullptr when unknown

}  // namespace ips::sim
