#pragma once
// Sorts UWB_RANGE messages into the survey's input: anchor-to-anchor ranges (tag_id is an anchor
// of the site, as when an anchor node ranges as the initiator) and the ranges of the tag standing
// at the known point within its time window. Pure: times are given by the caller (seconds since
// the start of the input: the log's first event, or the start of listening).
#include <Eigen/Core>
#include <cstdint>
#include <deque>
#include <ips/uwb_range_t.hpp>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/site.hpp"
#include "estimators/uwb_survey/anchor_survey.hpp"

namespace ips::uwb_survey {

struct CollectorOptions {
  std::string known_tag;  // empty: no known point
  double window_start_s = -std::numeric_limits<double>::infinity();
  double window_end_s = std::numeric_limits<double>::infinity();
  double max_range_m = 1000;  // longer, negative or non-finite ranges are invalid
  // Ranges held while no site is known yet (a log whose SITE comes late); beyond, dropped.
  size_t max_pending = 1'000'000;
};

struct CollectorStats {
  int64_t ranges_in = 0;
  int64_t anchor_pair = 0;  // kept as anchor-to-anchor ranges
  int64_t known_point = 0;  // kept as the known tag's ranges in the window
  int64_t invalid = 0;      // NaN, negative, beyond max_range_m
  int64_t other = 0;        // tags' ranges not used (other tags, outside the window)
  int64_t pending_dropped = 0;
  int64_t sites_ignored = 0;  // later SITEs whose text differs from the first
};

class RangeCollector {
 public:
  explicit RangeCollector(CollectorOptions opts) : opts_(std::move(opts)) {}

  // The first site is the one used; a later one with different text is counted and ignored (the
  // anchors' identities must not change in the middle of a survey).
  void set_site(const Site& site);
  bool has_site() const { return site_.has_value(); }
  const Site& site() const { return *site_; }

  void add(const uwb_range_t& m, double t_s);

  const CollectorStats& stats() const { return stats_; }
  // Samples per unordered anchor pair (ids in site order), for reporting what was heard.
  std::map<std::pair<std::string, std::string>, size_t> pair_counts() const;

  // The survey's input for `anchors` (survey order) and, when given, the known point's position.
  SurveyInput input(const std::vector<SurveyAnchor>& anchors,
                    const std::optional<Eigen::Vector3d>& known_position) const;

 private:
  struct Pending {
    std::string tag_id, anchor_id;
    double range_m, t_s;
  };
  void sort(const std::string& tag_id, const std::string& anchor_id, double range_m, double t_s);

  CollectorOptions opts_;
  std::optional<Site> site_;
  std::deque<Pending> pending_;
  // Anchor pairs keyed (initiator, responder) as received; the known tag's ranges by anchor.
  std::map<std::pair<std::string, std::string>, std::vector<double>> pair_ranges_;
  std::map<std::string, std::vector<double>> known_ranges_;
  CollectorStats stats_;
};

// The anchors to survey: the enabled `uwb` anchors of the site, `order` first (at least 3 ids
// when given: the first goes to the origin, the second on +x, the third in the +y half-plane),
// the others after them in site order. Heights from the site. Throws SurveyError for an id in
// `order` that is unknown, disabled, not `uwb` or repeated, or fewer than 3 anchors.
std::vector<SurveyAnchor> survey_order(const Site& site, const std::vector<std::string>& order);

}  // namespace ips::uwb_survey
