#include "drivers/sim/scenario.hpp"

#include <cmath>
#include <filesystem>
#include <stdexcept>
#include <vector>

namespace ips::sim {

const SensorSection* Scenario::sensor(const std::string& model_name) const {
  for (const auto& s : sensors)
    if (model_name == s.model->name) return &s;
  return nullptr;
}

namespace {
// A waypoint: [x, y] (at the walker's height), [x, y, z], or {at: [...], stop_s, speed_mps}.
Waypoint parse_waypoint(const YamlField& f, double height) {
  Waypoint w;
  YamlField at = f;
  if (f.is_map()) {
    f.check_keys({"at", "stop_s", "speed_mps"});
    at = f.required("at");
    w.stop_s = f.get_double("stop_s", 0.0);
    if (!(w.stop_s >= 0 && w.stop_s <= 1e7)) f["stop_s"].fail("must be in [0, 1e7]");
    if (f["speed_mps"].defined()) {
      w.speed_mps = f["speed_mps"].as_double();
      if (!(w.speed_mps > 0 && w.speed_mps <= 100)) f["speed_mps"].fail("must be in (0, 100]");
    }
  }
  if (at.is_sequence() && at.size() == 2) {
    const Eigen::Vector2d p = at.as_vec2();
    w.at = Eigen::Vector3d(p.x(), p.y(), height);
  } else if (at.is_sequence() && at.size() == 3) {
    w.at = at.as_vec3();
  } else {
    at.fail("expected [x, y], [x, y, z] or {at: [x, y, z], stop_s: S, speed_mps: V}");
  }
  if (w.at.cwiseAbs().maxCoeff() > 1e6) at.fail("coordinates must be within 1e6 m");
  return w;
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
    t.check_keys({"tag", "waypoints", "height_m", "speed_mps", "loop", "start_s"});
    std::string tag = t.required("tag").as_string();
    for (const auto& other : sc.trajectories)
      if (other.tag_id == tag) t["tag"].fail("tag '" + tag + "' already has a trajectory");
    const Tag* site_tag = sc.site.find_tag(tag);
    if (!site_tag) t["tag"].fail("tag '" + tag + "' is not in site.tags");
    auto wps = t.required("waypoints");
    if (!wps.is_sequence() || wps.size() < 2) wps.fail("expected at least 2 waypoints");
    const double height =
        t.get_double("height_m", std::isnan(site_tag->height_m) ? 1.2 : site_tag->height_m);
    const double speed = t.get_double("speed_mps", 1.0);
    if (!(speed > 0 && speed <= 100)) t["speed_mps"].fail("must be in (0, 100]");
    const double start_s = t.get_double("start_s", 0.0);
    if (!(start_s >= 0 && start_s <= 1e7)) t["start_s"].fail("must be in [0, 1e7]");
    std::vector<Waypoint> points;
    for (size_t k = 0; k < wps.size(); ++k) points.push_back(parse_waypoint(wps[k], height));
    try {
      sc.trajectories.push_back(
          {tag, WaypointTrajectory(points, speed, t.get_bool("loop", true), start_s)});
    } catch (const std::invalid_argument& e) {
      wps.fail(e.what());
    }
  }

  auto sensors = root["sensors"];
  if (sensors.defined() && !sensors.is_map()) sensors.fail("expected a map of sensor models");
  if (sensors.is_map()) {
    for (const auto& kv : sensors.node()) {
      const std::string key = kv.first.IsScalar() ? kv.first.Scalar() : "?";
      const SensorModel* model = nullptr;
      for (const auto& m : sensor_models())
        if (key == m.name) model = &m;
      if (!model) {
        std::string names;
        for (const auto& m : sensor_models()) names += (names.empty() ? "" : ", ") + std::string(m.name);
        YamlField(kv.first, origin, "sensors." + key).fail("unknown sensor model (known: " + names + ")");
      }
    }
  }
  for (const auto& m : sensor_models()) {
    YamlField section = sensors[m.name];
    const bool present = section.node().IsDefined();
    // Absent: off (TRUTH excepted, on with defaults). `name:` with no value: on, with defaults.
    if (!present && std::string(m.name) != "truth") continue;
    if (present && !section.node().IsNull() && !section.is_map())
      section.fail("expected a map of model parameters");
    if (section.get_bool("enabled", true)) sc.sensors.push_back({&m, section});
  }
  // Make every model's sources once, so that a bad parameter stops here, at start-up.
  const SimWorld world{sc.site, sc.trajectories, 0};
  for (const auto& s : sc.sensors) (void)s.model->make(s.section, world);
  return sc;
}

void replicate_walkers(Scenario& sc, int n) {
  if (n < 1 || n > 1000) throw ConfigError("--tags: must be in [1, 1000], got " + std::to_string(n));
  if (n == 1) return;
  YAML::Node root = YAML::Load(sc.site.yaml_text);
  const std::vector<TagTrajectory> originals = sc.trajectories;
  for (const auto& w : originals) {
    const Tag* tag = sc.site.find_tag(w.tag_id);
    const double spacing = w.path.loop() ? w.path.lap_s() / n : 2.0;
    for (int k = 2; k <= n; ++k) {
      const std::string id = w.tag_id + "-" + std::to_string(k);
      if (sc.site.find_tag(id)) throw ConfigError("--tags: tag id '" + id + "' already exists");
      YAML::Node t;
      t["id"] = id;
      if (tag && std::isfinite(tag->height_m)) t["height_m"] = tag->height_m;
      // A copy waits at the start of the same path: it starts where the original does.
      if (tag && tag->has_start()) {
        const Eigen::Vector3d& p = tag->start_position;
        t["start_position"] = std::vector<double>{p.x(), p.y(), p.z()};
      }
      if (tag && std::isfinite(tag->start_heading_rad))
        t["start_heading_deg"] = tag->start_heading_rad * 180.0 / M_PI;
      root["tags"].push_back(t);
      sc.trajectories.push_back({id, w.path.delayed((k - 1) * spacing)});
    }
  }
  YAML::Emitter out;
  out << root;
  Site site = parse_site_text(out.c_str(), sc.site.origin);
  site.estimators = sc.site.estimators;  // keep the marks of the original text for errors
  sc.site = site;
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
