#pragma once
// The site file ips-uwb-survey writes: the input site with the surveyed anchors' x and y
// replaced (to the millimetre), every other field as it was.
#include <string>
#include <vector>

#include "core/site.hpp"
#include "estimators/uwb_survey/anchor_survey.hpp"

namespace ips::uwb_survey {

// The site's YAML (site.yaml_text) with the x and y of each anchor in `surveyed` replaced; z and
// every other field keep their text and style (flow or block). YAML comments are not kept:
// `header` lines go first, each as a comment. The result parses with parse_site_text (checked:
// throws SurveyError if it would not, which is a bug).
std::string surveyed_site_yaml(const Site& site, const std::vector<SurveyedAnchor>& surveyed,
                               const std::vector<std::string>& header);

}  // namespace ips::uwb_survey
