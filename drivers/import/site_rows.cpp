#include "drivers/import/site_rows.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace ips::import {

namespace {

std::string number(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.4f", v);
  std::string s = buf;
  // Trim trailing zeros ("2.5775", "0.87", "0.0").
  while (s.size() > 1 && s.back() == '0' && s[s.size() - 2] != '.') s.pop_back();
  return s;
}

}  // namespace

std::string site_yaml_from_anchors(const std::string& name, const std::vector<AnchorSeen>& anchors,
                                   const std::vector<std::string>& tags,
                                   const std::vector<std::string>& header) {
  bool any_z = false;
  for (const AnchorSeen& a : anchors) any_z = any_z || a.has_z;
  std::string y;
  for (const std::string& h : header) y += "# " + h + "\n";
  y += "name: \"" + name + "\"\nanchors:\n";
  for (const AnchorSeen& a : anchors)
    y += "  - {id: \"" + a.id + "\", kind: uwb, position: [" + number(a.mean(0)) + ", " +
         number(a.mean(1)) + ", " + number(any_z ? a.mean(2) : 0.0) + "]}\n";
  if (!tags.empty()) {
    y += "tags:\n";
    for (const std::string& t : tags)
      y += any_z ? "  - {id: \"" + t + "\"}\n" : "  - {id: \"" + t + "\", height_m: 0.0}\n";
  }
  return y;
}

void merge_anchors(std::vector<AnchorSeen>& into, const std::vector<AnchorSeen>& more) {
  for (const AnchorSeen& m : more) {
    auto it = std::find_if(into.begin(), into.end(), [&](const AnchorSeen& a) { return a.id == m.id; });
    if (it == into.end()) {
      into.push_back(m);
      continue;
    }
    it->rows += m.rows;
    it->has_z = it->has_z || m.has_z;
    for (int k = 0; k < 3; ++k) {
      it->sum[k] += m.sum[k];
      it->min[k] = std::min(it->min[k], m.min[k]);
      it->max[k] = std::max(it->max[k], m.max[k]);
    }
  }
}

std::vector<int64_t> site_times(int64_t first_utime, int64_t last_utime, double every_s) {
  std::vector<int64_t> out{first_utime};
  if (!(every_s > 0)) return out;
  const double step = every_s * 1e6;
  for (int64_t k = 1;; ++k) {
    const double t = static_cast<double>(first_utime) + static_cast<double>(k) * step;
    if (t > static_cast<double>(last_utime) || out.size() > 10'000'000) break;
    out.push_back(static_cast<int64_t>(std::llround(t)));
  }
  return out;
}

}  // namespace ips::import
