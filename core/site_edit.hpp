#pragma once
// Editing a site's YAML (Site::yaml_text) to write results into it, as the calibration tools do
// (ips-aoa-calibrate: estimators.aoa.calibration; ips-altitude calibrate:
// estimators.altitude.offsets_pa). Comments of the input are not kept (yaml-cpp drops them).
#include <string>
#include <vector>
#include <yaml-cpp/yaml.h>

#include "core/site.hpp"

namespace ips {

class SiteYamlEdit {
 public:
  // Throws ConfigError when the site's YAML does not parse or is not a map.
  explicit SiteYamlEdit(const Site& site);

  YAML::Node root() { return root_; }
  // The map at root.k1.k2..., created where missing; ConfigError when something that is not a map
  // (nor null) is in the way.
  YAML::Node map_at(const std::vector<std::string>& keys);
  // The YAML text, each header line as a leading comment; it parses back as a site or this
  // throws ConfigError.
  std::string text(const std::vector<std::string>& header) const;

 private:
  YAML::Node root_;
};

}  // namespace ips
