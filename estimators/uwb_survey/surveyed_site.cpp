#include "estimators/uwb_survey/surveyed_site.hpp"

#include <yaml-cpp/yaml.h>

#include <cstdio>

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
  YAML::Node root;
  try {
    root = YAML::Load(site.yaml_text);
  } catch (const YAML::Exception& e) {
    throw SurveyError("the input site's YAML does not parse: " + std::string(e.what()));
  }
  YAML::Node anchors = root["anchors"];
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
  YAML::Emitter out;
  out << root;
  std::string text;
  for (const auto& line : header) text += "# " + line + "\n";
  text += out.c_str();
  text += "\n";
  try {
    parse_site_text(text, "the surveyed site");
  } catch (const ConfigError& e) {
    throw SurveyError(std::string("the surveyed site does not parse back: ") + e.what());
  }
  return text;
}

}  // namespace ips::uwb_survey
