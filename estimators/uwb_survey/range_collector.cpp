#include "estimators/uwb_survey/range_collector.hpp"

#include <cmath>
#include <set>

namespace ips::uwb_survey {

void RangeCollector::set_site(const Site& site) {
  if (site_) {
    if (site.yaml_text != site_->yaml_text) ++stats_.sites_ignored;
    return;
  }
  site_ = site;
  for (const auto& p : pending_) sort(p.tag_id, p.anchor_id, p.range_m, p.t_s);
  pending_.clear();
}

void RangeCollector::add(const uwb_range_t& m, double t_s) {
  ++stats_.ranges_in;
  if (!std::isfinite(m.range_m) || m.range_m < 0 || m.range_m > opts_.max_range_m) {
    ++stats_.invalid;
    return;
  }
  if (site_) {
    sort(m.tag_id, m.anchor_id, m.range_m, t_s);
    return;
  }
  if (pending_.size() >= opts_.max_pending) {
    ++stats_.pending_dropped;
    return;
  }
  pending_.push_back({m.tag_id, m.anchor_id, m.range_m, t_s});
}

void RangeCollector::sort(const std::string& tag_id, const std::string& anchor_id, double range_m,
                          double t_s) {
  if (site_->find_anchor(tag_id) && site_->find_anchor(anchor_id)) {
    pair_ranges_[{tag_id, anchor_id}].push_back(range_m);
    ++stats_.anchor_pair;
  } else if (!opts_.known_tag.empty() && tag_id == opts_.known_tag && t_s >= opts_.window_start_s &&
             t_s <= opts_.window_end_s && site_->find_anchor(anchor_id)) {
    known_ranges_[anchor_id].push_back(range_m);
    ++stats_.known_point;
  } else {
    ++stats_.other;
  }
}

std::map<std::pair<std::string, std::string>, size_t> RangeCollector::pair_counts() const {
  std::map<std::pair<std::string, std::string>, size_t> out;
  if (!site_) return out;
  auto rank = [&](const std::string& id) {
    for (size_t i = 0; i < site_->anchors.size(); ++i)
      if (site_->anchors[i].id == id) return i;
    return site_->anchors.size();
  };
  for (const auto& [k, v] : pair_ranges_) {
    auto key = rank(k.first) <= rank(k.second) ? k : std::make_pair(k.second, k.first);
    out[key] += v.size();
  }
  return out;
}

SurveyInput RangeCollector::input(const std::vector<SurveyAnchor>& anchors,
                                  const std::optional<Eigen::Vector3d>& known_position) const {
  SurveyInput in;
  in.anchors = anchors;
  for (const auto& [k, v] : pair_ranges_) in.pairs.push_back({k.first, k.second, v});
  if (known_position) {
    KnownPoint kp;
    kp.tag_id = opts_.known_tag;
    kp.position = *known_position;
    for (const auto& [anchor, v] : known_ranges_) kp.ranges.push_back({opts_.known_tag, anchor, v});
    in.known_point = kp;
  }
  return in;
}

std::vector<SurveyAnchor> survey_order(const Site& site, const std::vector<std::string>& order) {
  auto usable = [](const Anchor& a) { return a.kind == "uwb" && a.enabled; };
  std::vector<SurveyAnchor> out;
  std::set<std::string> taken;
  if (!order.empty() && order.size() < 3)
    throw SurveyError("anchor order: give at least 3 anchors (first, second, third), got " +
                      std::to_string(order.size()));
  for (const auto& id : order) {
    const Anchor* a = site.find_anchor(id);
    if (!a) throw SurveyError("anchor order: no anchor '" + id + "' in the site");
    if (!usable(*a))
      throw SurveyError(
          "anchor order: anchor '" + id + "' is " +
          (a->enabled ? "of kind " + a->kind + ", not uwb" : std::string("disabled")));
    if (!taken.insert(id).second) throw SurveyError("anchor order: '" + id + "' is listed twice");
    out.push_back({id, a->position.z()});
  }
  for (const auto& a : site.anchors)
    if (usable(a) && !taken.count(a.id)) out.push_back({a.id, a.position.z()});
  if (out.size() < 3)
    throw SurveyError("the site has " + std::to_string(out.size()) +
                      " enabled uwb anchors; a survey needs at least 3");
  return out;
}

}  // namespace ips::uwb_survey
