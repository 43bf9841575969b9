#pragma once
// UWB anchor self-survey: the horizontal positions of the anchors from anchor-to-anchor ranges,
// their heights known (../shared/reference/001_hybrid_uwb_ins.md §3.3.3, "WR positions (ABC)"):
//   - the first anchor at the origin, the second on +x at the first-to-second distance;
//   - the third by the law of cosines, x3 = (d12² + d13² − d23²) / (2·d12),
//     y3 = +√(d13² − x3²) (the source prints 2·d23 and x3 under the root: typos);
//   - every further anchor by least squares from its ranges to the anchors already placed;
//   - then one joint least-squares adjustment of all free coordinates (Levenberg-Marquardt on the
//     3D range residuals with the heights fixed), the gauge held by the first anchor at the origin
//     and the second on +x;
//   - the mirror ambiguity (±y) resolved by a tag standing at a known point: of the solution and
//     its reflection, the one whose distances to the point fit the tag's ranges better wins. The
//     source resolves it the same way (a fix of the mobile unit at its start point).
// Pure: values in, values out. Errors are SurveyError with a reason naming the anchors or pair.
#include <Eigen/Core>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace ips::uwb_survey {

struct SurveyError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// An anchor to place, with its known height (m, site frame).
struct SurveyAnchor {
  std::string id;
  double height_m = 0;
};

// The ranges measured between two anchors, in either direction (m).
struct PairRanges {
  std::string a, b;
  std::vector<double> ranges_m;
};

// A tag standing at a known point of the survey frame (first anchor at the origin, second on +x)
// and its ranges to the anchors meanwhile.
struct KnownPoint {
  std::string tag_id;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  std::vector<PairRanges> ranges;  // a = tag_id, b = anchor id
};

struct SurveyInput {
  // In survey order: [0] goes to the origin, [1] on +x, [2] in the +y half-plane (before the
  // mirror test); the others are placed in this order as soon as they range to 3 placed anchors.
  std::vector<SurveyAnchor> anchors;
  std::vector<PairRanges> pairs;  // a pair may appear more than once (both directions): merged
  std::optional<KnownPoint> known_point;
};

struct SurveyOptions {
  // The per-pair range is this quantile of its samples. Non-line-of-sight only ever lengthens a
  // range, so the median ignores up to half of the samples being NLOS whatever their size, where
  // a mean would be pulled up by every one; a lower quantile (e.g. 0.25) tolerates more NLOS
  // but is biased short by about 0.67 noise sigmas on clean ranges.
  double range_quantile = 0.5;
  // A pair with fewer samples counts as missing (the source's campaign used 100 per pair).
  int min_samples_per_pair = 10;
  // The first three anchors are degenerate (collinear) when the third lies closer than
  // max(min_offset_m, min_offset_ratio · d12) to the line through the first two.
  double min_offset_m = 0.2;
  double min_offset_ratio = 0.05;
  // The known point must tell the reflections apart by at least this much residual RMS (m).
  double min_mirror_separation_m = 0.05;
};

// One anchor pair as used in the adjustment.
struct PairReport {
  std::string a, b;
  size_t samples = 0;
  double range_m = 0;       // the robust range (quantile of the samples)
  double horizontal_m = 0;  // √(range² − Δz²), 0 when the range is shorter than Δz
  double fitted_m = 0;      // 3D distance between the surveyed positions
  double residual_m = 0;    // range − fitted
};

struct SurveyedAnchor {
  std::string id;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // survey frame; z = the given height
  int pairs_used = 0;
  double residual_rms_m = 0;  // RMS of the residuals of its pairs (0 with no redundancy)
};

enum class MirrorChoice {
  kConvention,  // no known point: the third anchor is kept in the +y half-plane
  kKept,        // the known point confirms +y for the third anchor
  kReflected,   // the known point picked the reflection: the third anchor is at −y
};

struct SurveyResult {
  std::vector<SurveyedAnchor> anchors;  // in survey order
  std::vector<PairReport> pairs;        // in survey order of (a, b)
  double residual_rms_m = 0;            // over all pairs
  int redundancy = 0;                   // pairs − free coordinates
  int iterations = 0;                   // of the joint adjustment
  MirrorChoice mirror = MirrorChoice::kConvention;
  // The known point's range residual RMS for the solution kept and for its reflection (NaN
  // without a known point), and the number of anchors it ranged to.
  double known_point_rms_m = std::numeric_limits<double>::quiet_NaN();
  double known_point_mirror_rms_m = std::numeric_limits<double>::quiet_NaN();
  int known_point_anchors = 0;
  std::vector<std::string> warnings;  // e.g. the known point fits poorly
};

// The q-quantile of `values` (linear interpolation between order statistics); NaN when empty.
double quantile(std::vector<double> values, double q);

// Throws SurveyError: fewer than 3 anchors, a duplicate or unknown id, a needed pair missing or
// with too few samples ("pair A2-A3: 4 ranges, fewer than 10"), collinear first three anchors,
// an anchor whose ranged partners are collinear, a known point that does not tell the
// reflections apart.
SurveyResult survey_anchors(const SurveyInput& input, const SurveyOptions& options = {});

}  // namespace ips::uwb_survey
