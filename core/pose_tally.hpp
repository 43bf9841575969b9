#pragma once
// What a tracker counts between two poses it publishes: the measurements used and their
// residuals, and whether the track restarted. Fills pose_t's num_used, residual_m and status,
// the same way for every estimator.
#include <cmath>
#include <ips/pose_t.hpp>
#include <limits>

#include "core/time.hpp"

namespace ips {

struct PoseTally {
  int used = 0;
  double sq_residual_m2 = 0;
  bool reinitialised = false;
  utime_t last_publish_utime = 0;

  void add(double residual_m) {
    ++used;
    sq_residual_m2 += residual_m * residual_m;
  }
  void add_many(int n, double sum_sq_residual_m2) {
    used += n;
    sq_residual_m2 += sum_sq_residual_m2;
  }
  // A track (re)started from a fix of n measurements with this residual RMS: what came before
  // it is not counted; a restart after a published pose is flagged REINITIALISED.
  void restart(int n, double rms_residual_m) {
    reinitialised = last_publish_utime != 0;
    used = n;
    sq_residual_m2 = rms_residual_m * rms_residual_m * n;
  }
  // At most one pose per period_s (0: every time).
  bool due(utime_t now, double period_s) const {
    return last_publish_utime == 0 || now - last_publish_utime >= s_to_utime(period_s);
  }
  // num_used, residual_m (RMS, NaN without measurements) and the status bits (OK, 2D, COASTING,
  // REINITIALISED); then starts counting afresh from `now`.
  void finish(pose_t& p, bool planar, utime_t now) {
    p.num_used = used;
    p.residual_m = used > 0 ? std::sqrt(sq_residual_m2 / used)
                            : std::numeric_limits<double>::quiet_NaN();
    p.status = pose_t::STATUS_OK;
    if (planar) p.status |= pose_t::STATUS_2D;
    if (used == 0) p.status |= pose_t::STATUS_COASTING;
    if (reinitialised) p.status |= pose_t::STATUS_REINITIALISED;
    reinitialised = false;
    used = 0;
    sq_residual_m2 = 0;
    last_publish_utime = now;
  }
};

}  // namespace ips
