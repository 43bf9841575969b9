#pragma once
// Which floor a tag is on, from its height: the floor whose surface, plus the height the tag is
// carried at, is nearest; a change is taken only after the new floor has been the nearest for
// dwell_s, so a tag on the stairs or a lift does not flicker between floors. Pure.
#include <cmath>
#include <vector>

#include "core/time.hpp"

namespace ips::altitude {

struct FloorParams {
  std::vector<double> heights_m;  // floor surfaces above the site origin, ascending; empty: off
  int first_index = 0;            // the index of heights_m[0] (-1 for a basement, ...)
  double carry_height_m = 1.0;    // the tag's height above the floor it is on
  double dwell_s = 2.0;
};

class FloorDetector {
 public:
  // False while no floor is known (no floors configured, or no height yet).
  bool valid() const { return current_ >= 0; }
  int floor(const FloorParams& p) const { return p.first_index + current_; }

  void update(const FloorParams& p, utime_t t, double height_m) {
    if (p.heights_m.empty() || !std::isfinite(height_m)) return;
    int nearest = 0;
    for (int i = 1; i < static_cast<int>(p.heights_m.size()); ++i)
      if (std::abs(height_m - p.carry_height_m - p.heights_m[static_cast<size_t>(i)]) <
          std::abs(height_m - p.carry_height_m - p.heights_m[static_cast<size_t>(nearest)]))
        nearest = i;
    if (current_ < 0 || nearest == current_) {
      current_ = nearest;
      candidate_ = -1;
      return;
    }
    if (nearest != candidate_) {
      candidate_ = nearest;
      candidate_since_ = t;
    }
    if (t - candidate_since_ >= s_to_utime(p.dwell_s)) {
      current_ = nearest;
      candidate_ = -1;
    }
  }

 private:
  int current_ = -1;  // index into heights_m
  int candidate_ = -1;
  utime_t candidate_since_ = 0;
};

}  // namespace ips::altitude
