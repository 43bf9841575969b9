#include "core/site.hpp"

#include <cmath>
#include <map>
#include <set>

namespace ips {

namespace {
constexpr double kDegToRad = M_PI / 180.0;
}

const Anchor* Site::find_anchor(const std::string& id) const {
  for (const auto& a : anchors)
    if (a.id == id) return &a;
  return nullptr;
}

const Tag* Site::find_tag(const std::string& id) const {
  for (const auto& t : tags)
    if (t.id == id) return &t;
  return nullptr;
}

YamlField Site::estimator_params(const std::string& estimator) const {
  return estimators[estimator];
}

Site parse_site(const YamlField& root) {
  if (!root.is_map()) root.fail("expected a site map (name, anchors, tags)");
  root.check_keys({"name", "anchors", "baro_stations", "tags", "estimators", "floors", "zones",
                   "alerts", "plan_images"});
  Site site;
  site.origin = root.origin();
  site.name = root.get_string("name", "unnamed");
  std::set<std::string> ids;

  auto anchors = root.required("anchors");
  if (!anchors.is_sequence()) anchors.fail("expected a list of anchors");
  for (size_t i = 0; i < anchors.size(); ++i) {
    auto a = anchors[i];
    a.check_keys({"id", "kind", "position", "orientation_deg", "enabled"});
    Anchor anchor;
    anchor.id = a.required("id").as_string();
    if (anchor.id.empty()) a["id"].fail("must not be empty");
    if (!ids.insert(anchor.id).second) a["id"].fail("duplicate anchor id '" + anchor.id + "'");
    anchor.kind = a.get_string("kind", "uwb");
    if (anchor.kind != "uwb" && anchor.kind != "uwb_tdoa" && anchor.kind != "ble_aoa")
      a["kind"].fail("unknown kind '" + anchor.kind + "' (uwb, uwb_tdoa, ble_aoa)");
    anchor.position = a.required("position").as_vec3();
    if (anchor.position.cwiseAbs().maxCoeff() > 1e6) a["position"].fail("must be within 1e6 m");
    if (a["orientation_deg"].defined())
      anchor.orientation_rad = a["orientation_deg"].as_vec3() * kDegToRad;
    anchor.enabled = a.get_bool("enabled", true);
    site.anchors.push_back(anchor);
  }

  auto stations = root["baro_stations"];
  if (stations.defined() && !stations.is_sequence()) stations.fail("expected a list");
  for (size_t i = 0; i < stations.size(); ++i) {
    stations[i].check_keys({"id", "position"});
    BaroStation s;
    s.id = stations[i].required("id").as_string();
    if (s.id.empty()) stations[i]["id"].fail("must not be empty");
    if (!ids.insert(s.id).second) stations[i]["id"].fail("duplicate id '" + s.id + "'");
    s.position = stations[i].required("position").as_vec3();
    site.baro_stations.push_back(s);
  }

  auto tags = root["tags"];
  if (tags.defined() && !tags.is_sequence()) tags.fail("expected a list of tags");
  std::set<std::string> tag_ids;
  for (size_t i = 0; i < tags.size(); ++i) {
    tags[i].check_keys({"id", "height_m", "start_position", "start_heading_deg"});
    Tag t;
    t.id = tags[i].required("id").as_string();
    if (t.id.empty()) tags[i]["id"].fail("must not be empty");
    if (!tag_ids.insert(t.id).second) tags[i]["id"].fail("duplicate tag id '" + t.id + "'");
    t.height_m = tags[i].get_double("height_m", std::numeric_limits<double>::quiet_NaN());
    const YamlField start = tags[i]["start_position"];
    if (start.defined()) {
      if (start.size() == 2) {
        t.start_position.head<2>() = start.as_vec2();
        t.start_position.z() = std::isfinite(t.height_m) ? t.height_m : 0.0;
      } else {
        t.start_position = start.as_vec3();
      }
      if (t.start_position.cwiseAbs().maxCoeff() > 1e6) start.fail("must be within 1e6 m");
    }
    if (tags[i]["start_heading_deg"].defined()) {
      const double h = tags[i]["start_heading_deg"].as_double();
      if (!(std::abs(h) <= 360)) tags[i]["start_heading_deg"].fail("must be in [-360, 360]");
      t.start_heading_rad = h * kDegToRad;
    }
    site.tags.push_back(t);
  }

  auto est = root["estimators"];
  if (est.defined() && !est.is_map()) est.fail("expected a map of estimator sections");
  site.estimators = est;
  site.layout = parse_site_layout(root);

  YAML::Emitter out;
  out << root.node();
  site.yaml_text = out.c_str();
  return site;
}

Site parse_site_text(const std::string& yaml_text, const std::string& origin) {
  Site site = parse_site(parse_yaml_text(yaml_text, origin));
  site.yaml_text = yaml_text;  // keep the user's text (comments, layout) in SITE messages
  return site;
}

Site load_site_text(const std::string& text, const std::string& path) {
  const YamlField root = parse_yaml_text(text, path);
  if (!root.is_map()) return parse_site(root);  // its error
  return parse_site_text(text + embed_plan_images(root, path), path);
}

Site load_site_file(const std::string& path) { return load_site_text(read_text_file(path), path); }

std::string missing_anchor_kind(const Site& site, const std::string& kind,
                                const std::string& program) {
  std::map<std::string, int> kinds;
  for (const Anchor& a : site.anchors) {
    if (!a.enabled) continue;
    if (a.kind == kind) return "";
    ++kinds[a.kind];
  }
  std::string has;
  for (const auto& [k, n] : kinds) has += (has.empty() ? "" : ", ") + std::to_string(n) + " " + k;
  return "site '" + site.name + "'" + (site.origin.empty() ? "" : " (" + site.origin + ")") +
         " has no enabled " + kind + " anchor (" + (has.empty() ? "it has none" : "it has " + has) +
         "): " + program + " estimates nothing until a site with them arrives";
}

site_t site_to_msg(const Site& site, utime_t utime, const std::string& source) {
  site_t m;
  m.utime = utime;
  m.source = source;
  m.name = site.name;
  for (const auto& a : site.anchors) {
    anchor_t am;
    am.id = a.id;
    am.kind = a.kind;
    for (int k = 0; k < 3; ++k) {
      am.position[k] = a.position[k];
      am.orientation_rad[k] = a.orientation_rad[k];
    }
    am.enabled = a.enabled;
    m.anchors.push_back(am);
  }
  m.num_anchors = static_cast<int32_t>(m.anchors.size());
  for (const auto& s : site.baro_stations) {
    baro_station_t sm;
    sm.id = s.id;
    for (int k = 0; k < 3; ++k) sm.position[k] = s.position[k];
    m.baro_stations.push_back(sm);
  }
  m.num_baro_stations = static_cast<int32_t>(m.baro_stations.size());
  for (const auto& t : site.tags) {
    tag_t tm;
    tm.id = t.id;
    tm.height_m = t.height_m;
    m.tags.push_back(tm);
  }
  m.num_tags = static_cast<int32_t>(m.tags.size());
  m.site_yaml = site.yaml_text;
  return m;
}

Site site_from_msg(const site_t& msg) {
  return parse_site_text(msg.site_yaml, "SITE message from " + msg.source);
}

}  // namespace ips
