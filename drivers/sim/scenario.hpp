#pragma once
// A simulator scenario: a site, one trajectory per tag, and sensor error models
// (docs/site-file.md). Built-in scenarios are the files of config/scenarios/, compiled in.
#include <string>
#include <vector>

#include "core/site.hpp"
#include "drivers/sim/trajectory.hpp"

namespace ips::sim {

struct TagTrajectory {
  std::string tag_id;
  WaypointTrajectory path;
};

struct TruthModel {
  double rate_hz = 50.0;
};

// Two-way ranging between every enabled UWB anchor and every tag.
struct UwbTwrModel {
  bool enabled = false;
  double rate_hz = 10.0;         // per anchor and tag
  double noise_sigma_m = 0.10;   // Gaussian
  double bias_m = 0.0;           // constant
  double nlos_probability = 0.0; // per range
  double nlos_bias_min_m = 0.3;  // NLOS adds a uniform positive bias in [min, max]
  double nlos_bias_max_m = 1.5;
  double loss_probability = 0.0;
  double max_range_m = 100.0;
};

struct Scenario {
  std::string name;
  double duration_s = 60.0;
  double site_period_s = 5.0;
  Site site;
  std::vector<TagTrajectory> trajectories;
  TruthModel truth;
  UwbTwrModel uwb_twr;
};

// Parses a scenario from YAML text; throws ConfigError naming file, line, field and reason.
Scenario parse_scenario_text(const std::string& text, const std::string& origin);

// Loads NAME (a built-in scenario) or FILE (a path to a scenario file). Throws ConfigError with
// the list of built-in names when NAME is neither.
Scenario load_scenario(const std::string& name_or_file);

// Built-in scenario names and their YAML text.
std::vector<std::string> builtin_scenario_names();
const char* builtin_scenario_text(const std::string& name);  // nullptr when unknown

}  // namespace ips::sim
