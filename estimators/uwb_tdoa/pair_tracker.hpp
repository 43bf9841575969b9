#pragma once
// Tags tracked from pairwise TDoA (uwb_tdoa_t on UWB_TDOA), as Loco-style systems deliver it:
// the clocks were synchronised upstream, each message is one range difference
// diff_m = |p - b| - |p - a|. Per tag a constant-velocity EKF (2D at the tag's height from the
// site, or 3D) with one scalar update per pair (models/tdoa_pair.hpp: Crazyflie's mm_tdoa) and
// the pair gate there (chi-square per pair, an integrator that declares the track lost). A track
// starts, and restarts when lost or after max_coast_s without an accepted pair, from a
// least-squares fix over the tag's pairs of the last pair_window_s (solve_pair_fix: several
// starts, an NLOS anchor left out or the worst pairs trimmed; a fix more than 2 m outside the
// anchors' box waits), so it converges from anywhere inside the site.
// Pure: uwb_tdoa_t in, pose_t out through a callback; message time only.
#include <deque>
#include <functional>
#include <ips/pose_t.hpp>
#include <ips/uwb_tdoa_t.hpp>
#include <map>
#include <span>
#include <string>
#include <vector>

#include "core/consistency.hpp"
#include "core/cv_filter.hpp"
#include "core/pose_tally.hpp"
#include "core/site.hpp"
#include "estimators/uwb_tdoa/models/tdoa_pair.hpp"

namespace ips::uwb_tdoa {

struct PairParams {
  bool force_3d = false;
  double pair_sigma_m = 0.1;      // sigma of a difference whose message gives none
  double pair_gate_sigma = 3.0;   // chi-square gate, in sigmas of the innovation
  double pair_lost_level = 20.0;  // gate integrator level at which the track restarts
  double pair_lost_share = 0.4;   // share of refused pairs above which the integrator climbs
  double pair_window_s = 0.25;    // pairs a fix is made of (the newest of each anchor pair)
  double accel_psd = 0.5;
  double init_velocity_sigma_mps = 1.0;
  double init_max_residual_m = 0.3;  // a fix with a larger RMS residual (after trimming) waits
  double max_coast_s = 3.0;
  double publish_period_s = 0.1;
  double reorder_tolerance_s = 0.05;
  int max_tags = 1000;
};

struct PairStats {
  int64_t pairs_in = 0;
  int64_t pairs_used = 0;               // applied to a track (or in a starting fix)
  int64_t pairs_gated = 0;              // refused by the chi-square gate
  int64_t pairs_geometry = 0;           // |diff| beyond the anchors' separation
  int64_t pairs_invalid = 0;            // NaN, bad ids, a == b, implausible time, bad sigma
  int64_t pairs_unknown_anchor = 0;     // not an enabled uwb_tdoa anchor of the site
  int64_t pairs_no_site = 0;
  int64_t pairs_late = 0;               // behind the tag's newest beyond reorder_tolerance_s
  int64_t pairs_initialising = 0;       // held for a fix while the tag has no track
  int64_t pairs_too_many_tags = 0;
  int64_t initialisations = 0;
  int64_t lost = 0;                     // tracks restarted by the gate integrator
  int64_t poses_out = 0;
};

// One difference for a fix: anchors a and b, diff = |p - b| - |p - a|.
struct PairObservation {
  Eigen::Vector3d a, b;
  double diff_m = 0;
};

struct PairFix {
  bool ok = false;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Matrix3d covariance_unit = Eigen::Matrix3d::Zero();  // (J'J)^-1, scale by sigma^2
  double residual_rms_m = 0;
  int used = 0;  // pairs left after trimming
};

// Least-squares position from pairs (Levenberg-Marquardt from the anchors' centroid and from near
// each anchor, the lowest cost kept), robust to NLOS: the fix of all pairs when its RMS residual
// is within 2 noise_sigma_m; else the cleanest fix with one anchor's pairs left out (an
// obstructed anchor biases every pair it is in) when that one is; else pairs with the largest
// residual dropped one by one while the RMS exceeds max_residual_m, never below min_pairs (at
// least dims + 2; the tracker asks dims + 3 where the site has the anchors: a set with one
// redundant pair can fit a wrong place). ok when the fix found is within max_residual_m.
PairFix solve_pair_fix(std::vector<PairObservation> pairs, bool fixed_height, double height_m,
                       double max_residual_m, double noise_sigma_m, int min_pairs);

class PairTracker {
 public:
  using PoseSink = std::function<void(const pose_t&)>;
  PairTracker(PoseSink sink, std::string source_name);

  // Anchors (enabled uwb_tdoa), tag heights and parameters; drops every track. `consistency`
  // (may be null) gets every pair's innovation as kind TDOA_PAIR, source "A>B".
  void configure(const Site& site, const PairParams& params, ConsistencyMonitor* consistency);
  void on_pair(const uwb_tdoa_t& m);

  const PairStats& stats() const { return stats_; }

 private:
  struct Track {
    bool planar = true;
    double height_m = 0;
    bool initialised = false;
    CvFilter<2> f2;
    CvFilter<3> f3;
    utime_t filter_utime = 0;
    utime_t newest_utime = 0;
    utime_t last_accept_utime = 0;
    PairGate gate;
    PoseTally tally;
    struct Held {
      utime_t utime;
      int a, b;
      double diff_m;
    };
    std::deque<Held> window;  // recent pairs, for a fix
  };
  void try_initialise(const std::string& tag_id, Track& t, utime_t now);
  template <int D>
  void update(const std::string& tag_id, Track& t, CvFilter<D>& f, int a, int b, double z,
              double r_var, utime_t now);
  template <int D>
  void publish(Track& t, const CvFilter<D>& f, const std::string& tag_id, utime_t now);
  int anchor_index(const std::string& id) const;

  PoseSink sink_;
  std::string source_;
  bool configured_ = false;
  PairParams p_;
  std::vector<std::string> anchor_ids_;
  std::vector<Eigen::Vector3d> anchor_pos_;
  std::map<std::string, std::pair<bool, double>> tag_height_;  // planar, height
  std::map<std::string, Track> tracks_;
  ConsistencyMonitor* consistency_ = nullptr;
  std::string setting_;
  PairStats stats_;
};

}  // namespace ips::uwb_tdoa
