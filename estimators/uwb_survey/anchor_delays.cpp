#include "estimators/uwb_survey/anchor_delays.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <deque>

namespace ips::uwb_survey {

namespace {

using PairKey = std::pair<size_t, size_t>;

std::string join(const std::vector<std::string>& items, const char* sep = ", ") {
  std::string out;
  for (const auto& s : items) out += (out.empty() ? "" : sep) + s;
  return out;
}

// Connected components of the used pairs' graph, each with whether it holds an odd cycle (is not
// two-colourable): only those determine their delays.
struct Component {
  std::vector<size_t> members;
  bool odd_cycle = false;
};

std::vector<Component> components(size_t n, const std::vector<PairKey>& edges) {
  std::vector<std::vector<size_t>> adj(n);
  for (const auto& [i, j] : edges) adj[i].push_back(j), adj[j].push_back(i);
  std::vector<int> colour(n, -1);
  std::vector<Component> out;
  for (size_t s = 0; s < n; ++s) {
    if (colour[s] >= 0) continue;
    Component c;
    colour[s] = 0;
    std::deque<size_t> queue{s};
    while (!queue.empty()) {
      const size_t u = queue.front();
      queue.pop_front();
      c.members.push_back(u);
      for (size_t v : adj[u]) {
        if (colour[v] < 0) {
          colour[v] = 1 - colour[u];
          queue.push_back(v);
        } else if (colour[v] == colour[u]) {
          c.odd_cycle = true;
        }
      }
    }
    std::sort(c.members.begin(), c.members.end());
    out.push_back(std::move(c));
  }
  return out;
}

}  // namespace

DelayResult solve_anchor_delays(const std::vector<KnownAnchor>& anchors,
                                const std::vector<PairRanges>& pairs, const DelayOptions& opt) {
  if (!(opt.range_quantile > 0 && opt.range_quantile <= 1))
    throw SurveyError("range quantile must be in (0, 1]");
  if (opt.min_samples_per_pair < 1)
    throw SurveyError("minimum samples per pair must be at least 1");
  const size_t n = anchors.size();
  if (n < 3)
    throw SurveyError("need at least 3 anchors (ranging in a triangle) for their delays, got " +
                      std::to_string(n));
  std::map<std::string, size_t> index;
  for (size_t i = 0; i < n; ++i) {
    if (!anchors[i].position.allFinite())
      throw SurveyError("anchor " + anchors[i].id + ": position is not finite");
    if (!index.emplace(anchors[i].id, i).second)
      throw SurveyError("anchor " + anchors[i].id + " is listed twice");
  }
  std::map<PairKey, std::vector<double>> samples;
  for (const auto& pr : pairs) {
    auto a = index.find(pr.a), b = index.find(pr.b);
    if (a == index.end() || b == index.end() || a->second == b->second) continue;
    auto& s = samples[{std::min(a->second, b->second), std::max(a->second, b->second)}];
    for (double r : pr.ranges_m)
      if (std::isfinite(r) && r >= 0) s.push_back(r);
  }

  DelayResult out;
  std::vector<PairKey> used;
  std::vector<size_t> used_report;  // index into out.pairs of each used pair
  std::vector<std::string> refused;
  for (const auto& [k, s] : samples) {
    if (s.empty()) continue;
    DelayPairReport p;
    p.a = anchors[k.first].id;
    p.b = anchors[k.second].id;
    p.samples = s.size();
    p.distance_m = (anchors[k.first].position - anchors[k.second].position).norm();
    p.range_m = quantile(s, opt.range_quantile);
    p.offset_m = p.range_m - p.distance_m;
    if (static_cast<int>(s.size()) < opt.min_samples_per_pair) {
      p.refused = std::to_string(s.size()) + " ranges, fewer than the " +
                  std::to_string(opt.min_samples_per_pair) + " required";
      refused.push_back(p.a + "-" + p.b + " (" + p.refused + ")");
    } else {
      used.push_back(k);
      used_report.push_back(out.pairs.size());
    }
    out.pairs.push_back(p);
  }

  std::vector<std::string> why, alone;
  for (const auto& c : components(n, used)) {
    if (c.odd_cycle) continue;
    std::vector<std::string> ids;
    for (size_t i : c.members) ids.push_back(anchors[i].id);
    if (c.members.size() == 1) {
      alone.push_back(ids[0]);
    } else {
      std::vector<std::string> names;
      for (const auto& [i, j] : used)
        if (std::find(c.members.begin(), c.members.end(), i) != c.members.end())
          names.push_back(anchors[i].id + "-" + anchors[j].id);
      why.push_back(join(ids) + " (their pairs " + join(names) +
                    " close no odd cycle such as a triangle, so +c and -c alternately fit alike)");
    }
  }
  if (!alone.empty()) why.insert(why.begin(), join(alone) + " (no pair used)");
  if (!why.empty())
    throw SurveyError("delays not determined: " + join(why, "; ") +
                      (refused.empty() ? std::string() : "; refused pairs: " + join(refused)));

  // Least squares of r_ij − |p_i − p_j| = d_i + d_j over the used pairs.
  const auto m = static_cast<Eigen::Index>(used.size());
  const auto nn = static_cast<Eigen::Index>(n);
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(m, nn);
  Eigen::VectorXd y(m);
  for (Eigen::Index r = 0; r < m; ++r) {
    const auto [i, j] = used[static_cast<size_t>(r)];
    A(r, static_cast<Eigen::Index>(i)) = 1;
    A(r, static_cast<Eigen::Index>(j)) = 1;
    y(r) = out.pairs[used_report[static_cast<size_t>(r)]].offset_m;
  }
  const Eigen::MatrixXd AtA = A.transpose() * A;
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(AtA);
  const Eigen::VectorXd d = ldlt.solve(A.transpose() * y);
  const Eigen::VectorXd res = y - A * d;
  out.redundancy = static_cast<int>(m - nn);
  out.residual_rms_m = m > 0 ? std::sqrt(res.squaredNorm() / static_cast<double>(m)) : 0.0;
  for (Eigen::Index r = 0; r < m; ++r)
    out.pairs[used_report[static_cast<size_t>(r)]].residual_m = res(r);
  // Covariance from the residual scatter; without redundancy there is none to go by.
  Eigen::MatrixXd cov = Eigen::MatrixXd::Constant(nn, nn, std::nan(""));
  if (out.redundancy > 0)
    cov = (res.squaredNorm() / out.redundancy) * ldlt.solve(Eigen::MatrixXd::Identity(nn, nn));

  out.tag_delay_m = d.mean();
  for (size_t i = 0; i < n; ++i) {
    const auto k = static_cast<Eigen::Index>(i);
    AnchorDelay a;
    a.id = anchors[i].id;
    a.delay_m = d(k);
    a.sigma_m = std::sqrt(cov(k, k));
    for (const auto& [pi, pj] : used) a.pairs_used += (pi == i || pj == i) ? 1 : 0;
    // seed = d_i + mean(d) = e' d with e = e_i + 1/n.
    Eigen::VectorXd e = Eigen::VectorXd::Constant(nn, 1.0 / static_cast<double>(n));
    e(k) += 1;
    a.seed_m = e.dot(d);
    a.seed_sigma_m = std::sqrt(e.dot(cov * e));
    out.anchors.push_back(a);
  }
  return out;
}

std::map<std::string, double> seeded_range_offsets(const DelayResult& result) {
  std::map<std::string, double> out;
  for (const auto& a : result.anchors) out[a.id] = a.seed_m;
  return out;
}

}  // namespace ips::uwb_survey
