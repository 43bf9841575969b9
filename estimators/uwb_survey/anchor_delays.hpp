#pragma once
// UWB antenna delays from anchor-to-anchor ranges between anchors at known positions (the site's),
// and the per-anchor range offsets they seed for the tag trackers
// (estimators.uwb_twr.range_offsets_m, read by ips-uwb-twr and ips-fuse).
//
// A two-way range reads long by the sum of the two devices' antenna delays (DW1000: the delay of
// each end's antenna and front end, counted once per exchange as a distance): for anchors i, j
//   r_ij − |p_i − p_j| = d_i + d_j  (+ noise),
// one equation per pair with the robust per-pair range (a quantile of its samples, the median by
// default: NLOS only lengthens ranges). The delays d solve it by least squares. A connected set of
// pairs determines its delays only if it holds an odd cycle (a triangle A1-A2-A3): with only even
// cycles (a chain, a square's four sides) d_i + c, d_j − c fits every pair alike (the pair graph
// is bipartite and the design matrix's null space is ±c alternating over its two colours).
//
// Seeding a tag's offsets needs the tag's own delay t, which no anchor-to-anchor range sees: it is
// taken as the mean of the anchors' delays (same radio and antenna model, so the same delay up to
// the unit-to-unit spread); a tag's seeded offset is then off by t − mean(d), which the trackers'
// online learning of the offsets (models/range_bias.hpp) then removes where the geometry lets it.
// Pure: values in, values out. Errors are SurveyError naming the anchors or pairs.
#include <Eigen/Core>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "estimators/uwb_survey/anchor_survey.hpp"

namespace ips::uwb_survey {

// An anchor at a known position (site frame, m).
struct KnownAnchor {
  std::string id;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
};

struct DelayOptions {
  double range_quantile = 0.5;    // the per-pair range: this quantile of its samples
  int min_samples_per_pair = 10;  // fewer: the pair is refused (reported, not used)
};

struct DelayPairReport {
  std::string a, b;
  size_t samples = 0;
  double range_m = 0;     // the robust range (quantile of the samples)
  double distance_m = 0;  // |p_a − p_b| from the known positions
  double offset_m = 0;    // range − distance: what d_a + d_b is fitted to
  double residual_m = std::numeric_limits<double>::quiet_NaN();  // offset − (d_a + d_b)
  std::string refused;  // why the pair is not used; empty when used
};

struct AnchorDelay {
  std::string id;
  double delay_m = 0;
  // From the residual scatter (s² (A'A)⁻¹, s² = Σ residual² / redundancy); NaN without
  // redundancy (a lone triangle fits exactly whatever the noise).
  double sigma_m = std::numeric_limits<double>::quiet_NaN();
  int pairs_used = 0;
  double seed_m = 0;  // the tag-anchor offset seeded: delay_m + the assumed tag delay
  double seed_sigma_m = std::numeric_limits<double>::quiet_NaN();  // of seed_m
};

struct DelayResult {
  std::vector<AnchorDelay> anchors;    // in input order
  std::vector<DelayPairReport> pairs;  // used and refused, in anchor order of (a, b)
  double residual_rms_m = 0;           // over the pairs used
  int redundancy = 0;                  // pairs used − anchors
  double tag_delay_m = 0;              // assumed: the mean of the anchors' delays
};

// Pairs naming an id not among `anchors` (a tag, a disabled anchor) or an anchor with itself are
// not ours and are skipped; a pair may appear more than once (both directions): merged.
// Throws SurveyError: fewer than 3 anchors, a duplicate id, a position not finite, bad options,
// or anchors whose delays the used pairs do not determine ("delays not determined: A5 (no pair
// used); refused pairs: A1-A5 (4 ranges, fewer than the 10 required)"), naming them and the pairs
// refused.
DelayResult solve_anchor_delays(const std::vector<KnownAnchor>& anchors,
                                const std::vector<PairRanges>& pairs,
                                const DelayOptions& options = {});

// The offsets to write into estimators.uwb_twr.range_offsets_m: one key per anchor (its id,
// meaning that anchor with every tag), value seed_m.
std::map<std::string, double> seeded_range_offsets(const DelayResult& result);

}  // namespace ips::uwb_survey
