#pragma once
// The best-master study of ../shared/reference/004_uwb_kf.md §3: a static tag is recorded once
// with each anchor as the sync master, and the masters are ranked by the spread of the tag's
// position estimates: the variance of the distance of the estimates from the known point (or,
// without one, from their mean). 004's best master (anchor 3, LOS to every other anchor) had
// variance 0.0096 m^2 (std 0.098 m, mean distance 0.232 m); its worst, without LOS to two
// anchors or the tag, 0.114 m^2.
//
// MasterRun replays one log's UWB_RX through the TDoA estimator and keeps one tag's estimates;
// the scoring and the table are plain functions. Pure: fed bytes and numbers, no file access.
#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/site.hpp"
#include "estimators/uwb_tdoa/tdoa_estimator.hpp"

namespace ips::uwb_tdoa {

struct MasterSpread {
  std::string label;   // where the estimates came from (the log's path)
  std::string master;  // the sync master of that run ("" when none was seen)
  std::string tag;
  size_t estimates = 0;
  double mean_distance_m = 0;  // mean distance of the estimates from the point
  double std_distance_m = 0;   // standard deviation of that distance
  double variance_m2 = 0;      // its variance (004's score; population variance, as numpy's var)
};

// Spread of `estimates` around `point` (horizontal distance, or 3D when use_height), or around
// their own mean when there is no point.
MasterSpread spread_of(const std::vector<Eigen::Vector3d>& estimates,
                       const std::optional<Eigen::Vector3d>& point, bool use_height);

// Best first: lowest variance; runs without estimates last. Stable for equal scores.
std::vector<MasterSpread> rank_masters(std::vector<MasterSpread> runs);

// The table ips-uwb-tdoa rank-masters prints: rank, master, estimates, mean distance, std,
// variance, log. Strings off the logs are made printable.
std::string format_master_ranking(const std::vector<MasterSpread>& ranked);

struct MasterRunOptions {
  std::string tag;  // empty: the first tag with an estimate
  std::string rx_channel = "UWB_RX";
  std::string site_channel = "SITE";
  std::optional<Site> site;  // instead of the log's SITE messages
  double skip_s = 0;         // estimates within this of the tag's first are not scored
};

class MasterRun {
 public:
  explicit MasterRun(MasterRunOptions opts);
  // One log event (channel, bytes). A SITE that does not parse, or whose parameters are bad, is
  // counted and skipped; so are messages that do not decode.
  void on_event(const std::string& channel, const uint8_t* data, size_t size);
  // After the last event: processes the blinks still open.
  void finish();

  const std::vector<Eigen::Vector3d>& estimates() const { return estimates_; }
  const std::string& tag() const { return tag_; }
  const std::string& master() const { return estimator_.master_id(); }
  int64_t bad_sites() const { return bad_sites_; }
  int64_t undecodable() const { return undecodable_; }
  const TdoaEstimator& estimator() const { return estimator_; }

 private:
  void on_pose(const pose_t& p);

  MasterRunOptions opts_;
  TdoaEstimator estimator_;
  std::string last_site_yaml_;
  std::string tag_;
  utime_t first_utime_ = 0;
  std::vector<Eigen::Vector3d> estimates_;
  int64_t bad_sites_ = 0;
  int64_t undecodable_ = 0;
};

}  // namespace ips::uwb_tdoa
