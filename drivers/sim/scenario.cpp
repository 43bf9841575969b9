#include "drivers/sim/scenario.hpp"

#include <cmath>
#include <filesystem>
#include <stdexcept>

namespace ips::sim {

namespace {

UwbTwrModel parse_uwb_twr(const YamlField& f) {
  UwbTwrModel m;
  if (!f.node().IsDefined()) return m;
  // `uwb_twr:` with nothing after it means the model with its defaults.
  m.enabled = true;
  if (f.node().IsNull()) return m;
  if (!f.is_map()) f.fail("expected a map of model parameters");
  f.check_keys({"enabled", "rate_hz", "noise_sigma_m", "bias_m", "nlos_probability",
                "nlos_bias_min_m", "nlos_bias_max_m", "loss_probability", "max_range_m"});
  m.enabled = f.get_bool("enabled", true);
  m.rate_hz = f.get_double("rate_hz", m.rate_hz);
  if (!(m.rate_hz >= 0.01 && m.rate_hz <= 1000)) f["rate_hz"].fail("must be in [0.01, 1000]");
  m.noise_sigma_m = f.get_double("noise_sigma_m", m.noise_sigma_m);
  if (m.noise_sigma_m < 0) f["noise_sigma_m"].fail("must not be negative");
  m.bias_m = f.get_double("bias_m", m.bias_m);
  m.nlos_probability = f.get_double("nlos_probability", m.nlos_probability);
  if (m.nlos_probability < 0 || m.nlos_probability > 1) f["nlos_probability"].fail("must be in [0, 1]");
  m.nlos_bias_min_m = f.get_double("nlos_bias_min_m", m.nlos_bias_min_m);
  m.nlos_bias_max_m = f.get_double("nlos_bias_max_m", m.nlos_bias_max_m);
  if (m.nlos_bias_max_m < m.nlos_bias_min_m) f["nlos_bias_max_m"].fail("must be >= nlos_bias_min_m");
  m.loss_probability = f.get_double("loss_probability", m.loss_probability);
  if (m.loss_probability < 0 || m.loss_probability > 1) f["loss_probability"].fail("must be in [0, 1]");
  m.max_range_m = f.get_double("max_range_m", m.max_range_m);
  return m;
}

}  // namespace

Scenario parse_scenario_text(const std::string& text, const std::string& origin) {
  YamlField root = parse_yaml_text(text, origin);
  if (!root.is_map()) root.fail("expected a scenario map (name, site, trajectories, sensors)");
  root.check_keys({"name", "duration_s", "site_period_s", "site", "trajectories", "sensors"});
  Scenario sc;
  sc.name = root.get_string("name", std::filesystem::path(origin).stem().string());
  sc.duration_s = root.get_double("duration_s", sc.duration_s);
  if (!(sc.duration_s > 0 && sc.duration_s <= 1e7)) root["duration_s"].fail("must be in (0, 1e7]");
  sc.site_period_s = root.get_double("site_period_s", sc.site_period_s);
  if (!(sc.site_period_s >= 0.1 && sc.site_period_s <= 3600))
    root["site_period_s"].fail("must be in [0.1, 3600]");
  sc.site = parse_site(root.required("site"));

  auto trajs = root.required("trajectories");
  if (!trajs.is_sequence() || trajs.size() == 0) trajs.fail("expected a list of trajectories");
  for (size_t i = 0; i < trajs.size(); ++i) {
    auto t = trajs[i];
    t.check_keys({"tag", "waypoints", "height_m", "speed_mps", "loop"});
    std::string tag = t.required("tag").as_string();
    for (const auto& other : sc.trajectories)
      if (other.tag_id == tag) t["tag"].fail("tag '" + tag + "' already has a trajectory");
    const Tag* site_tag = sc.site.find_tag(tag);
    if (!site_tag) t["tag"].fail("tag '" + tag + "' is not in site.tags");
    auto wps = t.required("waypoints");
    if (!wps.is_sequence() || wps.size() < 2) wps.fail("expected at least 2 waypoints [x, y]");
    std::vector<Eigen::Vector2d> points;
    for (size_t k = 0; k < wps.size(); ++k) points.push_back(wps[k].as_vec2());
    double height = t.get_double("height_m", std::isnan(site_tag->height_m) ? 1.2 : site_tag->height_m);
    double speed = t.get_double("speed_mps", 1.0);
    if (!(speed > 0 && speed <= 100)) t["speed_mps"].fail("must be in (0, 100]");
    for (size_t k = 0; k < points.size(); ++k)
      if (points[k].cwiseAbs().maxCoeff() > 1e6) wps[k].fail("coordinates must be within 1e6 m");
    try {
      sc.trajectories.push_back({tag, WaypointTrajectory(points, speed, height, t.get_bool("loop", true))});
    } catch (const std::invalid_argument& e) {
      wps.fail(e.what());
    }
  }

  auto sensors = root["sensors"];
  if (sensors.defined() && !sensors.is_map()) sensors.fail("expected a map of sensor models");
  sensors.check_keys({"truth", "uwb_twr"});
  sensors["truth"].check_keys({"rate_hz"});
  sc.truth.rate_hz = sensors["truth"].get_double("rate_hz", sc.truth.rate_hz);
  if (!(sc.truth.rate_hz >= 0.01 && sc.truth.rate_hz <= 1000))
    sensors["truth"]["rate_hz"].fail("must be in [0.01, 1000]");
  sc.uwb_twr = parse_uwb_twr(sensors["uwb_twr"]);
  return sc;
}

Scenario load_scenario(const std::string& name_or_file) {
  if (const char* text = builtin_scenario_text(name_or_file)) {
    return parse_scenario_text(text, "built-in scenario '" + name_or_file + "'");
  }
  std::error_code ec;
  if (std::filesystem::is_regular_file(name_or_file, ec)) {
    return parse_scenario_text(read_text_file(name_or_file), name_or_file);
  }
  std::string names;
  for (const auto& n : builtin_scenario_names()) names += (names.empty() ? "" : ", ") + n;
  throw ConfigError("unknown scenario '" + name_or_file +
                    "': not a built-in scenario (" + names + ") and not a readable file");
}

}  // namespace ips::sim
