#include "estimators/uwb_tdoa/master_ranking.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ips/site_t.hpp>

#include "core/node.hpp"
#include "core/text_escape.hpp"

namespace ips::uwb_tdoa {

MasterSpread spread_of(const std::vector<Eigen::Vector3d>& estimates,
                       const std::optional<Eigen::Vector3d>& point, bool use_height) {
  MasterSpread s;
  s.estimates = estimates.size();
  if (estimates.empty()) return s;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  if (point) {
    centre = *point;
  } else {
    for (const auto& e : estimates) centre += e;
    centre /= static_cast<double>(estimates.size());
  }
  double sum = 0, sum_sq = 0;
  for (const auto& e : estimates) {
    const Eigen::Vector3d d = e - centre;
    const double dist = use_height ? d.norm() : d.head<2>().norm();
    sum += dist;
    sum_sq += dist * dist;
  }
  const double n = static_cast<double>(estimates.size());
  s.mean_distance_m = sum / n;
  s.variance_m2 = std::max(0.0, sum_sq / n - s.mean_distance_m * s.mean_distance_m);
  s.std_distance_m = std::sqrt(s.variance_m2);
  return s;
}

std::vector<MasterSpread> rank_masters(std::vector<MasterSpread> runs) {
  std::stable_sort(runs.begin(), runs.end(), [](const MasterSpread& a, const MasterSpread& b) {
    if ((a.estimates == 0) != (b.estimates == 0)) return b.estimates == 0;
    return a.variance_m2 < b.variance_m2;
  });
  return runs;
}

std::string format_master_ranking(const std::vector<MasterSpread>& ranked) {
  std::string out;
  char line[512];
  std::snprintf(line, sizeof line, "%-4s %-10s %-8s %9s %14s %9s %12s  %s\n", "rank", "master",
                "tag", "estimates", "mean_dist_m", "std_m", "variance_m2", "log");
  out += line;
  int rank = 0;
  for (const auto& r : ranked) {
    ++rank;
    const std::string master = printable(r.master.empty() ? "-" : r.master);
    const std::string tag = printable(r.tag.empty() ? "-" : r.tag);
    if (r.estimates == 0) {
      std::snprintf(line, sizeof line, "%-4d %-10s %-8s %9zu %14s %9s %12s  %s\n", rank,
                    master.c_str(), tag.c_str(), r.estimates, "-", "-", "-",
                    printable(r.label).c_str());
    } else {
      std::snprintf(line, sizeof line, "%-4d %-10s %-8s %9zu %14.4f %9.4f %12.6f  %s\n", rank,
                    master.c_str(), tag.c_str(), r.estimates, r.mean_distance_m, r.std_distance_m,
                    r.variance_m2, printable(r.label).c_str());
    }
    out += line;
  }
  return out;
}

MasterRun::MasterRun(MasterRunOptions opts)
    : opts_(std::move(opts)),
      estimator_([this](const pose_t& p) { on_pose(p); }, [](const clock_t&) {}),
      tag_(opts_.tag) {
  if (opts_.site) estimator_.set_site(*opts_.site);
}

void MasterRun::on_pose(const pose_t& p) {
  if (tag_.empty()) tag_ = p.tag_id;
  if (p.tag_id != tag_) return;
  if (first_utime_ == 0) first_utime_ = p.utime;
  if (p.utime - first_utime_ < s_to_utime(opts_.skip_s)) return;
  if (!std::isfinite(p.position[0]) || !std::isfinite(p.position[1]) ||
      !std::isfinite(p.position[2]))
    return;
  estimates_.emplace_back(p.position[0], p.position[1], p.position[2]);
}

void MasterRun::on_event(const std::string& channel, const uint8_t* data, size_t size) {
  if (channel == opts_.site_channel && !opts_.site) {
    site_t m;
    if (!decode_message(m, data, size)) {
      ++undecodable_;
      return;
    }
    if (m.site_yaml == last_site_yaml_) return;
    last_site_yaml_ = m.site_yaml;
    try {
      estimator_.set_site(site_from_msg(m));
    } catch (const ConfigError&) {
      ++bad_sites_;
    }
  } else if (channel == opts_.rx_channel) {
    uwb_rx_t m;
    if (!decode_message(m, data, size)) {
      ++undecodable_;
      return;
    }
    estimator_.on_rx(m);
  }
}

void MasterRun::finish() { estimator_.flush(); }

}  // namespace ips::uwb_tdoa
