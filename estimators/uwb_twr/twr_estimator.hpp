#pragma once
// Two-way-ranging tag tracker: per-epoch Levenberg-Marquardt multilateration to initialise,
// (or Gauss-Newton, or Foy's method) to initialise, then a constant-velocity EKF per tag (2D with
// the tag height from the site, or 3D) with sequential range updates and Mahalanobis gating.
// NLOS (the direct path is blocked, so ranges are only ever too long): positive innovations are
// gated tighter and down-weighted (models/uwb_range.hpp); an anchor gated again and again triggers
// a check against a fresh fix, so a track caught in a wrong minimum (a mirror image) cannot
// persist by rejecting the anchors that disagree. With 1 or 2 anchors in view the track keeps going: the unobserved
// directions' covariance grows with the process noise instead of the estimate jumping.
// Pure: takes messages, emits pose_t through a callback, never reads a clock.
#include <deque>
#include <functional>
#include <ips/pose_t.hpp>
#include <ips/uwb_range_t.hpp>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/consistency.hpp"
#include "core/cv_filter.hpp"
#include "core/drop_reasons.hpp"
#include "core/multilateration.hpp"
#include "core/pose_tally.hpp"
#include "core/repeat_filter.hpp"
#include "core/site.hpp"
#include "core/time_guard.hpp"
#include "estimators/uwb_twr/models/range_bias.hpp"
#include "estimators/uwb_twr/models/uwb_range.hpp"

namespace ips::uwb_twr {

// The position sigma of a start from ranges with none to spare (3 in 2D, 4 in 3D): nothing
// checks them, and one may be NLOS by a metre or more (ips-uwb-twr and ips-fuse).
inline constexpr double kUncheckedStartSigmaM = 1.0;

struct TwrParams {
  bool force_3d = false;          // estimate height even when the site gives one
  // Per-epoch solver for (re-)initialisation.
  MultilaterationSolver init_solver = MultilaterationSolver::kLevenbergMarquardt;
  double range_sigma_m = 0.10;    // measurement noise
  double accel_psd = 0.5;         // process noise, (m/s^2)^2/Hz
  double gate_sigma = 4.0;        // reject |innovation| > gate_sigma * sqrt(S) (negative side)
  double nlos_gate_sigma = 2.5;   // the same for positive innovations (ranges too long)
  double nlos_downweight_sigma = 1.5;  // positive innovations beyond this are down-weighted
  double epoch_window_s = 0.2;    // ranges this close in time form one epoch for initialisation
  double init_velocity_sigma_mps = 1.0;
  // Consecutive gated ranges (of all anchors) that trigger re-initialisation; the same number
  // from one anchor triggers a check against a fresh per-epoch fix.
  int reinit_after_rejections = 12;
  double max_coast_s = 3.0;       // no accepted range for this long: re-initialise
  double publish_period_s = 0.1;  // at most one pose per tag per period
  double reorder_tolerance_s = 0.05;  // ranges this far behind the tag's newest are still used
  double max_range_m = 300.0;
  int max_tags = 1000;            // tracks kept at most (ids off the bus must not exhaust memory)
  // Learn each anchor's range noise from its innovations (core/consistency.hpp), within
  // [0.5, 10] x range_sigma_m.
  bool learn_noise = true;
  // NLOS by the receiver's powers (models/uwb_range.hpp, NlosPower): the likelihood rises from 0
  // at rx_power_dbm - fp_power_dbm = nlos_power_los_db (Decawave APS006: < 6 dB likely LOS) to 1
  // at nlos_power_db (> 10 dB likely NLOS); the range's variance is multiplied by 1 up to
  // nlos_power_var_scale with it. nlos_power_db 0 turns the indicator off.
  double nlos_power_los_db = 6.0;
  double nlos_power_db = 10.0;
  double nlos_power_var_scale = 10.0;
  NlosPower nlos_power() const { return {nlos_power_los_db, nlos_power_db, nlos_power_var_scale}; }
  // Range bias removed before use: range - (range_bias_m + range_bias_per_m * range). Off (0) by
  // default: the bias is the device's (docs/real-data.md, uwb-cucudasluv static ranges).
  double range_bias_m = 0.0;
  double range_bias_per_m = 0.0;
  // Known per-pair offsets (antenna delays), removed before use: "A1" for an anchor with any tag,
  // "T1/A1" for one pair (ips-uwb-calibrate writes them). The start of the learned offsets.
  std::map<std::string, double> range_offsets_m;
  // Known per-pair scale factors s, keyed as range_offsets_m: range = (1 + s) d + offset, so a
  // range is divided by 1 + s before its offset is taken off ([-0.1, 0.1]; ips-uwb-calibrate
  // --scale writes them). Not learned.
  std::map<std::string, double> range_scales;
  // Each tag-anchor pair's constant range offset learned online (RangeBias, models/
  // range_bias.hpp): real DW1000 pairs read long by +0.08 to +0.32 m each; unlearned, the
  // offset looks like NLOS to the asymmetric gate. bias_prior_sigma_m: its spread before any
  // range (an offset not configured); bias_window: ranges averaged at most (the offset drifts
  // with temperature over minutes); bias_max_m: the learned offset's bound.
  bool learn_bias = true;
  double bias_prior_sigma_m = 0.2;  // the pairs' common part (the tag's delay), before any range
  double bias_pair_sigma_m = 0.07;  // each pair's own part around it (the anchors' delays)
  int bias_window = 300;
  double bias_max_m = 0.6;
  // Publish a plain per-epoch least-squares fix (the newest range per anchor in the epoch, the
  // configured offsets removed, no gate, no filter) on POSE_UWB_EPOCH: the naive solution the
  // tracker must beat on real data (scripts/realdata). Off by default.
  bool epoch_fixes = false;
};

// Reads `estimators.uwb_twr` of the site; throws ConfigError on a bad value.
TwrParams parse_twr_params(const YamlField& section);

// A per-pair setting as the trackers read it (range_offsets_m, range_scales): "TAG/ANCHOR", else
// "ANCHOR", else NaN.
double pair_setting(const std::map<std::string, double>& values, const std::string& tag_id,
                    const std::string& anchor_id);

// A tag's per-pair range offsets as the site sets them up (range_offsets_m: "T1/A1", else "A1";
// learned unless learn_bias is off), one per site anchor: ips-uwb-twr's and ips-fuse's start.
PairOffsets initial_offsets(const TwrParams& p, const std::string& tag_id,
                            const std::vector<Anchor>& anchors);

struct TwrStats {
  int64_t ranges_in = 0;
  int64_t ranges_used = 0;
  int64_t rejected_gate = 0;
  int64_t downweighted = 0;            // accepted, with the variance inflated (long: NLOS?)
  int64_t nlos_power = 0;              // used ranges more likely NLOS than not by rx - fp power
  int64_t dropped_unknown_anchor = 0;  // anchor not in the site or disabled
  int64_t dropped_no_anchors = 0;      // the site has no enabled uwb anchor at all
  int64_t dropped_no_site = 0;
  int64_t dropped_invalid = 0;         // NaN, negative or absurd range, or implausible utime
  int64_t dropped_late = 0;            // older than the tag's newest range by reorder_tolerance_s
  int64_t dropped_duplicate = 0;       // a copy of a range already taken (core/repeat_filter.hpp)
  int64_t time_resets = 0;             // older by more than max_coast_s: track restarted
  int64_t dropped_too_many_tags = 0;   // a new tag id while max_tags tracks are active
  int64_t anchor_pair_ranges = 0;      // tag_id is an anchor of the site: survey input, not a tag
  int64_t ranges_initialising = 0;     // taken while the tag's track is not initialised
  int64_t initialisations = 0;
  int64_t reacquisitions = 0;          // re-initialised because a fresh fix disagreed with the track
  int64_t poses_out = 0;
  int64_t epoch_fixes_out = 0;         // POSE_UWB_EPOCH (epoch_fixes)

  // The ranges that gave no estimate, by reason (HEALTH, ips-replay's summary).
  DropReasons drop_reasons() const {
    DropReasons d;
    d.add(DropReason::kNoSite, dropped_no_site);
    d.add(DropReason::kNoAnchorsOfKind, dropped_no_anchors);
    d.add(DropReason::kUnknownAnchor, dropped_unknown_anchor);
    d.add(DropReason::kInvalid, dropped_invalid);
    d.add(DropReason::kLate, dropped_late);
    d.add(DropReason::kDuplicate, dropped_duplicate);
    d.add(DropReason::kTooManyTags, dropped_too_many_tags);
    d.add(DropReason::kInitialising, ranges_initialising);
    d.add(DropReason::kGated, rejected_gate);
    d.add(DropReason::kSurveyRange, anchor_pair_ranges);
    return d;
  }
};

class TwrEstimator {
 public:
  using PoseSink = std::function<void(const pose_t&)>;
  explicit TwrEstimator(PoseSink sink, std::string source_name = "uwb_twr");
  // Where the per-epoch least-squares fixes go when the site asks for them (epoch_fixes).
  void set_epoch_sink(PoseSink sink) { epoch_sink_ = std::move(sink); }

  // Takes the anchors, tag heights and parameters; resets all tracks.
  void set_site(const Site& site);
  bool has_site() const { return site_.has_value(); }
  void on_range(const uwb_range_t& msg);
  const TwrStats& stats() const { return stats_; }
  DropReasons drop_reasons() const {
    DropReasons d = stats_.drop_reasons();
    d.add(DropReason::kTimeJump, guard_.dropped());
    return d;
  }
  // Time plausibility of the inputs, per sender (core/time_guard.hpp).
  const TimeGuardStats& time_stats() const { return guard_.stats(); }
  const TwrParams& params() const { return params_; }
  // A pair's range offset as removed now (configured, then learned); NaN for an unknown pair.
  double range_offset_m(const std::string& tag_id, const std::string& anchor_id) const;
  // Each anchor's range innovations against range_sigma_m (core/consistency.hpp).
  const ConsistencyMonitor& consistency() const { return consistency_; }

 private:
  struct Epoch {
    utime_t utime;
    size_t anchor_index;  // into the site's anchors
    double range_m;       // less range_bias_m and range_bias_per_m, not the pair's offset
  };
  struct Track {
    std::string tag_id;
    bool planar = true;  // 2D with known height
    double height_m = 0;
    bool initialised = false;
    CvFilter<2> f2;
    CvFilter<3> f3;
    utime_t filter_utime = 0;
    utime_t newest_utime = 0;  // newest range seen, the reference for "late"
    utime_t last_accept_utime = 0;
    int consecutive_rejections = 0;
    PoseTally tally;  // since the last pose published
    std::deque<Epoch> recent;  // for (re)initialisation
    utime_t first_utime = 0;  // the track's first range
    std::vector<int> anchor_rejections;  // consecutive gated ranges per site anchor
    std::vector<utime_t> anchor_heard_utime;  // newest range per site anchor
    PairOffsets bias;  // per site anchor: this pair's offset (models/range_bias.hpp)
    double cycle_s = 0;  // how often an anchor is heard again (a round of the anchors), s
    utime_t last_epoch_fix_utime = 0;
    utime_t last_bias_utime = 0;  // the last epoch the offsets learned from
    bool check_fix = false;
    RecentRepeats repeats;  // the tag's last ranges, to know a copy
    std::vector<ConsistencyMonitor::LinkId> noise_links;  // per site anchor, made on first use
  };
  // The link (this tag, a site anchor) whose range noise is learned (core/consistency.hpp).
  ConsistencyMonitor::LinkId noise_link(Track& t, size_t anchor_index);
  // The epoch: at least epoch_window_s, and a round of the tag's anchors (radios that range one
  // anchor at a time, e.g. every 0.13 s in turn, take 0.5 s to hear four).
  utime_t epoch_window(const Track& t) const;
  // The newest range per anchor within the epoch, each less its pair's offset (learned, or
  // only the configured one); false when fewer anchors than a fix needs were heard.
  bool epoch_observations(const Track& t, utime_t now, bool learned,
                          std::vector<RangeObservation>& obs) const;
  void publish_epoch_fix(Track& t, const std::string& tag_id, utime_t now);
  // The pairs' offsets from an epoch's least-squares residuals (models/range_bias.hpp).
  void learn_offsets(Track& t, utime_t now);

  // Solves the newest range per anchor in the epoch window and starts the filter there; with
  // only_if_elsewhere, only when the fix lies outside what the track's covariance covers.
  bool try_initialise(Track& t, utime_t now, bool only_if_elsewhere = false);
  template <int D>
  void update(Track& t, CvFilter<D>& f, size_t anchor_index, const uwb_range_t& m);
  template <int D>
  void publish(Track& t, const CvFilter<D>& f, const std::string& tag_id, utime_t now);

  PoseSink sink_;
  PoseSink epoch_sink_;
  std::string source_;
  std::optional<Site> site_;
  TwrParams params_;
  std::map<std::string, Track> tracks_;
  int enabled_uwb_anchors_ = 0;
  TwrStats stats_;
  TimeGuard guard_;  // per sender (core/time_guard.hpp)
  ConsistencyMonitor consistency_;
  std::string range_setting_;  // "range_sigma_m 0.1", as the monitor names it
};

}  // namespace ips::uwb_twr
