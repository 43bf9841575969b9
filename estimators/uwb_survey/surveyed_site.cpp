#include "estimators/uwb_survey/surveyed_site.hpp"

#include <yaml-cpp/yaml.h>

#include <cstdio>

#include "core/site_edit.hpp"

namespace ips::uwb_survey {

namespace {
std::string millimetres(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.3f", v);
  return std::string(buf) == "-0.000" ? "0.000" : buf;
}
}  // namespace

std::string surveyed_site_yaml(const Site& site, const std::vector<SurveyedAnchor>& surveyed,
                               const std::vector<std::string>& header) {
  try {
    SiteYamlEdit edit(site);
    YAML::Node anchors = edit.root()["anchors"];
    size_t written = 0;
    for (const auto& s : surveyed) {
      for (YAML::Node a : anchors) {
        if (!a["id"] || a["id"].Scalar() != s.id) continue;
        YAML::Node p = a["position"];
        p[0] = millimetres(s.position.x());
        p[1] = millimetres(s.position.y());
        ++written;
      }
    }
    if (written != surveyed.size())
      throw SurveyError("surveyed anchors missing from the input site's YAML");
    return edit.text(header);
  } catch (const ConfigError& e) {
    throw SurveyError(e.what());
  }
}

}  // namespace ips::uwb_survey
