#include "estimators/uwb_survey/anchor_survey.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include "core/multilateration.hpp"

namespace ips::uwb_survey {

namespace {

std::string fmt_m(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3f", v);
  return buf;
}

// Samples of every pair, merged over both directions, keyed by survey indices (i < j).
using PairKey = std::pair<size_t, size_t>;

struct Pairs {
  std::map<PairKey, std::vector<double>> samples;
  std::map<PairKey, double> range_m;  // the robust range of each pair with enough samples
};

struct Geometry {
  const std::vector<SurveyAnchor>& anchors;
  const Pairs& pairs;
  const SurveyOptions& opt;

  std::string name(PairKey k) const { return anchors[k.first].id + "-" + anchors[k.second].id; }
  static PairKey key(size_t i, size_t j) { return i < j ? PairKey{i, j} : PairKey{j, i}; }
  const double* range(size_t i, size_t j) const {
    auto it = pairs.range_m.find(key(i, j));
    return it == pairs.range_m.end() ? nullptr : &it->second;
  }
  // Why pair (i, j) cannot be used: "no ranges" or "4 ranges, fewer than 10".
  std::string why_missing(size_t i, size_t j) const {
    auto it = pairs.samples.find(key(i, j));
    if (it == pairs.samples.end() || it->second.empty()) return "no ranges";
    return std::to_string(it->second.size()) + " ranges, fewer than the " +
           std::to_string(opt.min_samples_per_pair) + " required";
  }
  double need(size_t i, size_t j, const std::string& what) const {
    if (const double* r = range(i, j)) return *r;
    throw SurveyError("pair " + name(key(i, j)) + ": " + why_missing(i, j) + " (needed " + what +
                      ")");
  }
  // Horizontal distance: the range with the known height difference removed. A range shorter
  // than the height difference (noise on nearly stacked anchors) gives 0.
  double horizontal(size_t i, size_t j, double r) const {
    const double dz = anchors[i].height_m - anchors[j].height_m;
    return std::sqrt(std::max(0.0, r * r - dz * dz));
  }
};

// Spread of 2D points across their best-fitting line: the smaller principal standard deviation.
double spread_across_line(const std::vector<Eigen::Vector2d>& pts) {
  Eigen::Vector2d c = Eigen::Vector2d::Zero();
  for (const auto& p : pts) c += p;
  c /= static_cast<double>(pts.size());
  Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
  for (const auto& p : pts) cov += (p - c) * (p - c).transpose();
  cov /= static_cast<double>(pts.size());
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(cov);
  return std::sqrt(std::max(0.0, es.eigenvalues()(0)));
}

// Places anchor `k` from its ranges to the placed anchors `partners`: linear least squares on the
// squared horizontal distances (each circle minus the first one's: Fang's linearisation) for a
// start, then Levenberg-Marquardt on the 3D ranges with the anchor's height fixed.
Eigen::Vector2d place_by_least_squares(const Geometry& g, size_t k,
                                       const std::vector<size_t>& partners,
                                       const std::vector<Eigen::Vector2d>& pos) {
  const size_t p0 = partners[0];
  const double h0 = g.horizontal(k, p0, *g.range(k, p0));
  Eigen::MatrixXd A(static_cast<Eigen::Index>(partners.size() - 1), 2);
  Eigen::VectorXd b(A.rows());
  for (size_t m = 1; m < partners.size(); ++m) {
    const size_t p = partners[m];
    const double h = g.horizontal(k, p, *g.range(k, p));
    const auto row = static_cast<Eigen::Index>(m - 1);
    A.row(row) = 2.0 * (pos[p] - pos[p0]).transpose();
    b(row) = h0 * h0 - h * h + pos[p].squaredNorm() - pos[p0].squaredNorm();
  }
  const Eigen::Vector2d start = A.colPivHouseholderQr().solve(b);

  std::vector<RangeObservation> obs;
  for (size_t p : partners)
    obs.push_back({Eigen::Vector3d(pos[p].x(), pos[p].y(), g.anchors[p].height_m), *g.range(k, p)});
  MultilaterationOptions mo;
  mo.fixed_height = true;
  mo.height_m = g.anchors[k].height_m;
  mo.convergence_m = 1e-7;
  mo.divergence_m = 1e6;
  const MultilaterationResult res =
      multilaterate_lm(obs, mo, Eigen::Vector3d(start.x(), start.y(), mo.height_m));
  if (!res.ok) throw SurveyError("cannot place anchor " + g.anchors[k].id + ": " + res.failure);
  return res.position.head<2>();
}

// The free coordinates: x of the second anchor, then x, y of the third and every further one.
Eigen::VectorXd pack(const std::vector<Eigen::Vector2d>& pos) {
  Eigen::VectorXd t(static_cast<Eigen::Index>(2 * pos.size() - 3));
  t(0) = pos[1].x();
  for (size_t i = 2; i < pos.size(); ++i) {
    t(static_cast<Eigen::Index>(2 * i - 3)) = pos[i].x();
    t(static_cast<Eigen::Index>(2 * i - 2)) = pos[i].y();
  }
  return t;
}

std::vector<Eigen::Vector2d> unpack(const Eigen::VectorXd& t, size_t n) {
  std::vector<Eigen::Vector2d> pos(n, Eigen::Vector2d::Zero());
  pos[1].x() = t(0);
  for (size_t i = 2; i < n; ++i)
    pos[i] = {t(static_cast<Eigen::Index>(2 * i - 3)), t(static_cast<Eigen::Index>(2 * i - 2))};
  return pos;
}

// Range residuals (measured − fitted 3D distance) of every usable pair and, when J is given,
// their Jacobian with respect to the free coordinates (negated: d fitted / d t).
Eigen::VectorXd adjustment_residuals(const Geometry& g, const std::vector<PairKey>& keys,
                                     const Eigen::VectorXd& t, Eigen::MatrixXd* J) {
  const size_t n = g.anchors.size();
  const auto pos = unpack(t, n);
  auto col = [](size_t anchor, int axis) -> Eigen::Index {  // -1: fixed by the gauge
    if (anchor == 0) return -1;
    if (anchor == 1) return axis == 0 ? 0 : -1;
    return static_cast<Eigen::Index>(2 * anchor - 3 + static_cast<size_t>(axis));
  };
  Eigen::VectorXd r(static_cast<Eigen::Index>(keys.size()));
  if (J) *J = Eigen::MatrixXd::Zero(r.size(), t.size());
  for (size_t m = 0; m < keys.size(); ++m) {
    const auto [i, j] = keys[m];
    const Eigen::Vector3d d(pos[i].x() - pos[j].x(), pos[i].y() - pos[j].y(),
                            g.anchors[i].height_m - g.anchors[j].height_m);
    const double dist = std::max(d.norm(), 1e-9);
    const auto row = static_cast<Eigen::Index>(m);
    r(row) = g.pairs.range_m.at(keys[m]) - dist;
    if (!J) continue;
    for (int axis = 0; axis < 2; ++axis) {
      if (const Eigen::Index c = col(i, axis); c >= 0) (*J)(row, c) += d(axis) / dist;
      if (const Eigen::Index c = col(j, axis); c >= 0) (*J)(row, c) -= d(axis) / dist;
    }
  }
  return r;
}

// Joint Levenberg-Marquardt (Marquardt's diagonal scaling) over all free coordinates.
int adjust(const Geometry& g, const std::vector<PairKey>& keys, std::vector<Eigen::Vector2d>& pos) {
  Eigen::VectorXd t = pack(pos);
  Eigen::MatrixXd J;
  Eigen::VectorXd r = adjustment_residuals(g, keys, t, &J);
  double cost = r.squaredNorm();
  double lambda = 1e-3;
  int it = 0;
  for (; it < 200; ++it) {
    const Eigen::MatrixXd A = J.transpose() * J;
    const Eigen::VectorXd grad = J.transpose() * r;
    Eigen::MatrixXd Ad = A;
    Ad.diagonal() += lambda * A.diagonal().cwiseMax(1e-12);
    const Eigen::VectorXd step = Ad.ldlt().solve(grad);
    if (!step.allFinite()) break;
    const Eigen::VectorXd candidate = t + step;
    const Eigen::VectorXd r_new = adjustment_residuals(g, keys, candidate, nullptr);
    const double new_cost = r_new.squaredNorm();
    if (new_cost <= cost) {
      t = candidate;
      cost = new_cost;
      r = adjustment_residuals(g, keys, t, &J);
      lambda = std::max(lambda / 10, 1e-12);
      if (step.norm() < 1e-10) break;
    } else {
      lambda *= 10;
      if (lambda > 1e12) break;  // no step lowers the cost: at the minimum
    }
  }
  pos = unpack(t, pos.size());
  return it;
}

}  // namespace

double quantile(std::vector<double> values, double q) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(values.begin(), values.end());
  const double at = std::clamp(q, 0.0, 1.0) * static_cast<double>(values.size() - 1);
  const auto lo = static_cast<size_t>(std::floor(at));
  const size_t hi = std::min(lo + 1, values.size() - 1);
  return values[lo] + (at - static_cast<double>(lo)) * (values[hi] - values[lo]);
}

SurveyResult survey_anchors(const SurveyInput& in, const SurveyOptions& opt) {
  if (!(opt.range_quantile > 0 && opt.range_quantile <= 1))
    throw SurveyError("range quantile must be in (0, 1]");
  if (opt.min_samples_per_pair < 1)
    throw SurveyError("minimum samples per pair must be at least 1");
  const auto& anchors = in.anchors;
  const size_t n = anchors.size();
  if (n < 3) throw SurveyError("need at least 3 anchors to survey, got " + std::to_string(n));
  std::map<std::string, size_t> index;
  for (size_t i = 0; i < n; ++i) {
    if (!std::isfinite(anchors[i].height_m))
      throw SurveyError("anchor " + anchors[i].id + ": height is not a finite number");
    if (!index.emplace(anchors[i].id, i).second)
      throw SurveyError("anchor " + anchors[i].id + " is listed twice");
  }

  // Pairs naming an id that is not among the anchors are not ours (a tag, a disabled anchor).
  Pairs pairs;
  for (const auto& pr : in.pairs) {
    auto a = index.find(pr.a), b = index.find(pr.b);
    if (a == index.end() || b == index.end() || a->second == b->second) continue;
    auto& s = pairs.samples[Geometry::key(a->second, b->second)];
    for (double r : pr.ranges_m)
      if (std::isfinite(r) && r >= 0) s.push_back(r);
  }
  SurveyResult out;
  const Geometry g{anchors, pairs, opt};
  for (const auto& [k, s] : pairs.samples) {
    if (static_cast<int>(s.size()) >= opt.min_samples_per_pair)
      pairs.range_m[k] = quantile(s, opt.range_quantile);
    else if (!s.empty())
      out.warnings.push_back("pair " + g.name(k) + ": " + g.why_missing(k.first, k.second) +
                             ": not used");
  }

  // ABC: the first three anchors.
  std::vector<Eigen::Vector2d> pos(n, Eigen::Vector2d::Zero());
  std::vector<bool> placed(n, false);
  const std::string first3 = anchors[0].id + ", " + anchors[1].id + ", " + anchors[2].id;
  const double d12 = g.horizontal(0, 1, g.need(0, 1, "to place " + anchors[1].id + " on +x"));
  const double d13 = g.horizontal(0, 2, g.need(0, 2, "to place " + anchors[2].id));
  const double d23 = g.horizontal(1, 2, g.need(1, 2, "to place " + anchors[2].id));
  if (d12 < opt.min_offset_m)
    throw SurveyError("anchors " + anchors[0].id + " and " + anchors[1].id + " are " + fmt_m(d12) +
                      " m apart horizontally: too close to define the x axis; choose another "
                      "second anchor");
  const double x3 = (d12 * d12 + d13 * d13 - d23 * d23) / (2 * d12);
  const double y3 = std::sqrt(std::max(0.0, d13 * d13 - x3 * x3));
  const double min_offset = std::max(opt.min_offset_m, opt.min_offset_ratio * d12);
  if (y3 < min_offset)
    throw SurveyError("anchors " + first3 + " are (nearly) collinear: " + anchors[2].id + " is " +
                      fmt_m(y3) + " m from the line " + anchors[0].id + "-" + anchors[1].id +
                      " (at least " + fmt_m(min_offset) +
                      " m needed); choose a third anchor off that line");
  pos[1] = {d12, 0};
  pos[2] = {x3, y3};
  placed[0] = placed[1] = placed[2] = true;

  // Every further anchor as soon as it has ranges to 3 placed anchors not on one line.
  for (size_t remaining = n - 3; remaining > 0; --remaining) {
    bool progress = false;
    for (size_t k = 3; k < n && !progress; ++k) {
      if (placed[k]) continue;
      std::vector<size_t> partners;
      std::vector<Eigen::Vector2d> partner_pos;
      for (size_t p = 0; p < n; ++p)
        if (placed[p] && g.range(k, p)) {
          partners.push_back(p);
          partner_pos.push_back(pos[p]);
        }
      if (partners.size() < 3 || spread_across_line(partner_pos) < opt.min_offset_m) continue;
      pos[k] = place_by_least_squares(g, k, partners, pos);
      placed[k] = true;
      progress = true;
    }
    if (progress) continue;
    // Name the first anchor that cannot be placed, its partners and the pairs it lacks.
    size_t k = 3;
    while (placed[k]) ++k;
    std::string have, missing;
    for (size_t p = 0; p < n; ++p) {
      if (!placed[p]) continue;
      if (g.range(k, p))
        have += (have.empty() ? "" : ", ") + anchors[p].id;
      else
        missing += (missing.empty() ? "" : "; ") + g.name(Geometry::key(p, k)) + ": " +
                   g.why_missing(k, p);
    }
    throw SurveyError("cannot place anchor " + anchors[k].id + ": it has ranges to " +
                      (have.empty() ? std::string("none") : have) +
                      " of the placed anchors, and needs 3 not on one line" +
                      (missing.empty() ? std::string() : "; missing pairs: " + missing));
  }

  // The joint adjustment over every usable pair.
  std::vector<PairKey> keys;
  for (const auto& [k, r] : pairs.range_m) keys.push_back(k);
  out.iterations = adjust(g, keys, pos);
  // The adjustment starts on the +y side and never needs to cross the x axis; should it have,
  // reflecting everything restores the convention without changing any distance.
  if (pos[2].y() < 0)
    for (auto& p : pos) p.y() = -p.y();

  // The mirror test: the tag's ranges at the known point against both reflections.
  if (in.known_point) {
    const KnownPoint& kp = *in.known_point;
    std::map<size_t, std::vector<double>> tag_ranges;
    for (const auto& pr : kp.ranges) {
      auto a = index.find(pr.b);
      if (pr.a != kp.tag_id || a == index.end()) continue;
      for (double r : pr.ranges_m)
        if (std::isfinite(r) && r >= 0) tag_ranges[a->second].push_back(r);
    }
    double ss_kept = 0, ss_mirror = 0;
    int used = 0;
    std::string seen;
    for (const auto& [i, rs] : tag_ranges) {
      const double r = quantile(rs, opt.range_quantile);
      const Eigen::Vector3d a(pos[i].x(), pos[i].y(), anchors[i].height_m);
      const Eigen::Vector3d m(pos[i].x(), -pos[i].y(), anchors[i].height_m);
      ss_kept += std::pow(r - (kp.position - a).norm(), 2);
      ss_mirror += std::pow(r - (kp.position - m).norm(), 2);
      ++used;
      seen += (seen.empty() ? "" : ", ") + anchors[i].id;
    }
    if (used < 3)
      throw SurveyError("known point: tag " + kp.tag_id + " has ranges to " +
                        (used ? seen : std::string("no surveyed anchor")) +
                        " while at the point; 3 anchors are needed to tell the reflections apart");
    out.known_point_anchors = used;
    const double kept = std::sqrt(ss_kept / used), mirror = std::sqrt(ss_mirror / used);
    if (std::abs(kept - mirror) < opt.min_mirror_separation_m)
      throw SurveyError(
          "known point (" + fmt_m(kp.position.x()) + ", " + fmt_m(kp.position.y()) + ", " +
          fmt_m(kp.position.z()) + ") does not tell the reflections apart (range residual RMS " +
          fmt_m(kept) + " m with " + anchors[2].id + " at +y, " + fmt_m(mirror) +
          " m at -y); choose a point away from the line " + anchors[0].id + "-" + anchors[1].id);
    if (mirror < kept) {
      for (auto& p : pos) p.y() = -p.y();
      out.mirror = MirrorChoice::kReflected;
      out.known_point_rms_m = mirror;
      out.known_point_mirror_rms_m = kept;
    } else {
      out.mirror = MirrorChoice::kKept;
      out.known_point_rms_m = kept;
      out.known_point_mirror_rms_m = mirror;
    }
    if (out.known_point_rms_m > 0.3)
      out.warnings.push_back("the tag's ranges at the known point fit poorly (residual RMS " +
                             fmt_m(out.known_point_rms_m) +
                             " m): check the point, its height and the time window");
  }

  // Report: residuals per pair and per anchor.
  const Eigen::VectorXd r = adjustment_residuals(g, keys, pack(pos), nullptr);
  std::vector<double> ss(n, 0.0);
  out.anchors.resize(n);
  for (size_t m = 0; m < keys.size(); ++m) {
    const auto [i, j] = keys[m];
    const double res = r(static_cast<Eigen::Index>(m));
    PairReport pr;
    pr.a = anchors[i].id;
    pr.b = anchors[j].id;
    pr.samples = pairs.samples.at(keys[m]).size();
    pr.range_m = pairs.range_m.at(keys[m]);
    pr.horizontal_m = g.horizontal(i, j, pr.range_m);
    pr.fitted_m = pr.range_m - res;
    pr.residual_m = res;
    out.pairs.push_back(pr);
    for (size_t a : {i, j}) {
      ss[a] += res * res;
      ++out.anchors[a].pairs_used;
    }
    out.residual_rms_m += res * res;
  }
  out.residual_rms_m = std::sqrt(out.residual_rms_m / static_cast<double>(keys.size()));
  out.redundancy = static_cast<int>(keys.size()) - static_cast<int>(2 * n - 3);
  for (size_t i = 0; i < n; ++i) {
    auto& a = out.anchors[i];
    a.id = anchors[i].id;
    a.position = {pos[i].x(), pos[i].y(), anchors[i].height_m};
    a.residual_rms_m = a.pairs_used ? std::sqrt(ss[i] / a.pairs_used) : 0.0;
  }
  return out;
}

}  // namespace ips::uwb_survey
