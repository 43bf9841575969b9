#pragma once
// The site: anchors, reference barometers, tags and per-estimator parameters, loaded from a YAML
// site file (docs/site-file.md) or taken from a SITE message.
#include <Eigen/Core>
#include <functional>
#include <ips/site_t.hpp>
#include <limits>
#include <string>
#include <vector>

#include "core/site_layout.hpp"
#include "core/time.hpp"
#include "core/yaml_fields.hpp"

namespace ips {

using SiteError = ConfigError;

struct Anchor {
  std::string id;
  std::string kind = "uwb";  // uwb, uwb_tdoa, ble_aoa
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Vector3d orientation_rad = Eigen::Vector3d::Zero();  // roll, pitch, yaw
  bool enabled = true;
};

struct BaroStation {
  std::string id;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
};

struct Tag {
  std::string id;
  double height_m = std::numeric_limits<double>::quiet_NaN();  // NaN: estimate height (3D)
  // Where the tag starts, for the relative estimators (dead reckoning, INS): NaN when not given.
  Eigen::Vector3d start_position =
      Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  double start_heading_rad = std::numeric_limits<double>::quiet_NaN();  // from +x, CCW
  bool has_start() const { return start_position.head<2>().allFinite(); }
};

struct Site {
  std::string name;
  std::vector<Anchor> anchors;
  std::vector<BaroStation> baro_stations;
  std::vector<Tag> tags;
  SiteLayout layout;      // floors and their plans, zones, alert rules
  std::string yaml_text;  // the site as YAML, carried in site_t so logs are self-contained
  std::string origin;     // file name (or "SITE message") for error messages
  // The `estimators:` map, with its marks in the original text for error messages.
  YamlField estimators{YAML::Node(YAML::NodeType::Undefined), "", "estimators"};

  const Anchor* find_anchor(const std::string& id) const;
  const Tag* find_tag(const std::string& id) const;
  // The `estimators.<name>` section (may be undefined: every parameter has a default).
  YamlField estimator_params(const std::string& estimator) const;
};

// Parses a site from a YAML map (a site file's root, or a scenario's `site:`).
Site parse_site(const YamlField& root);
Site parse_site_text(const std::string& yaml_text, const std::string& origin);
// A site file's text, read from `path`: the plan images it names are read (relative to it) and
// carried in the site (embed_plan_images); errors keep the file's own line numbers.
Site load_site_text(const std::string& text, const std::string& path);
Site load_site_file(const std::string& path);

// "" when the site has an enabled anchor of `kind` (uwb, uwb_tdoa, ble_aoa); else what
// `program` (an estimator of such anchors) has to say: "site 'lab' (config/sites/lab.yaml) has
// no enabled ble_aoa anchor (it has 4 uwb): ips-aoa estimates nothing until a site with them
// arrives".
std::string missing_anchor_kind(const Site& site, const std::string& kind,
                                const std::string& program);

site_t site_to_msg(const Site& site, utime_t utime, const std::string& source);
// Throws SiteError when the message's site_yaml does not parse.
Site site_from_msg(const site_t& msg);

}  // namespace ips
