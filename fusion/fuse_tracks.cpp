// FuseEstimator's tracks: one per tag, found or added for each input (and restarted after a
// gap or a jump back in time), started from the site's start pose, a multilateration of ranges or
// the hosted TDoA / AoA trackers' fix, and widened when the tag is lost.
#include "fusion/fuse_estimator.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <optional>
#include <vector>

#include "core/geometry.hpp"
#include "core/multilateration.hpp"
#include "core/text_escape.hpp"
#include "estimators/uwb_twr/models/uwb_range.hpp"
#include "fusion/fuse_inputs.hpp"

namespace ips::fusion {

namespace {
constexpr double kPlanarVar = 1e-12;  // z and vz in 2D: known
}  // namespace

FuseEstimator::Track* FuseEstimator::track_for_checked(const std::string& tag_id, utime_t t,
                                                       int64_t hosted_reanchors_back,
                                                       int64_t& seen_reanchors_back) {
  // The hosted estimator's guard went back in time since its last epoch: so does the tag.
  const bool went_back = hosted_reanchors_back != seen_reanchors_back;
  seen_reanchors_back = hosted_reanchors_back;
  if (!guard_.note(tag_id, t, went_back)) {
    ++stats_.messages_in;
    ++stats_.dropped_late;  // old work handed over late (a blink closed after a silence)
    return nullptr;
  }
  if (went_back) restart_track(tag_id);
  guard_.release();  // the tag's messages held meanwhile that this stamp confirmed
  return find_or_add_track(tag_id, t);
}

void FuseEstimator::restart_track(const std::string& tag_id) {
  // Time went back: nothing the track holds is of the new timeline. Its tally stays, so that the
  // next pose is flagged REINITIALISED.
  auto it = tracks_.find(tag_id);
  if (it == tracks_.end()) return;
  Track fresh;
  fresh.tag_id = tag_id;
  fresh.tally = it->second.tally;
  fresh.ever_started = it->second.ever_started;
  fresh.absolute_seen = it->second.absolute_seen;
  it->second = std::move(fresh);
}

FuseEstimator::Track* FuseEstimator::find_or_add_track(const std::string& tag_id, utime_t t) {
  ++stats_.messages_in;
  auto it = tracks_.find(tag_id);
  if (it == tracks_.end()) {
    if (static_cast<int>(tracks_.size()) >= params_.max_tags) {
      ++stats_.dropped_too_many_tags;
      return nullptr;
    }
    it = tracks_.try_emplace(tag_id).first;
    it->second.tag_id = tag_id;
  }
  Track& track = it->second;
  if (track.initialised && t - track.newest > s_to_utime(params_.max_gap_s)) {
    // Nothing of the tag for longer than any coasting can bridge (the process stopped, the
    // machine swapped, the tag out of reach): extrapolating across would publish a confident
    // guess. The track starts afresh from the next fix, its first pose flagged REINITIALISED.
    track.initialised = false;
    track.history.clear();
    track.snapshots.clear();
    track.recent_ranges.clear();
    track.waiting_since = 0;
    track.have_last_dr = false;
    ++stats_.gap_restarts;
    char text[160];
    std::snprintf(text, sizeof text, "%.1f s without input, track restarted from fresh measurements",
                  utime_to_s(t - track.newest));
    last_gap_ = printable(tag_id) + ": " + text;
  }
  // A start pose in the site wins over everything else, for the first start.
  // (The site looked up only then: not for every message of a running track.)
  if (!track.initialised && !track.ever_started) {
    const Tag* tag = site_->find_tag(tag_id);
    if (tag && tag->has_start()) {
      Eigen::Vector3d p = tag->start_position;
      if (!std::isfinite(p.z())) p.z() = std::isfinite(tag->height_m) ? tag->height_m : 0.0;
      start(tag_id, track, t, p, params_.start_sigma_m, true);
    }
  }
  return &track;
}

void FuseEstimator::start(const std::string& tag_id, Track& t, utime_t time,
                          const Eigen::Vector3d& p, double sigma_m, bool prior) {
  FuseFilter f;
  f.planar = planar_for(tag_id);
  f.x.head<3>() = p;
  f.P.setZero();
  for (int i = 0; i < 3; ++i) {
    f.P(i, i) = sigma_m * sigma_m;
    f.P(kVel + i, kVel + i) = 1.0;
  }
  new_frame(f);  // the heading bias of the dead-reckoning source unknown
  if (f.planar) {
    f.x(2) = tag_height(tag_id);
    f.P(2, 2) = kPlanarVar;
    f.P(kVel + 2, kVel + 2) = kPlanarVar;
  }
  if (t.initialised) ++stats_.restarts;
  t.initialised = true;
  t.ever_started = true;
  t.state = Snapshot{time, time, f, time, 0, prior};
  // A start from measurements (a fix of the ranges, a pose) is one of the horizontal position: a
  // dead-reckoning frame first heard right after it is measured against the track's path.
  if (!prior) t.state.last_horizontal = time;
  t.prior_unchecked = prior;
  t.started_at = time;
  t.lost_checks = 0;
  t.base = t.state;
  t.history.clear();
  t.snapshots.clear();
  t.recent_ranges.clear();
  t.waiting_since = 0;
  t.newest = std::max(t.newest, time);
  t.tally.restart(0, 0);
  ++stats_.initialisations;
}

std::optional<FuseEstimator::RangeFix> FuseEstimator::fix_from_ranges(const std::string& tag_id,
                                                                     Track& t) {
  if (t.recent_ranges.empty()) return std::nullopt;
  const utime_t newest = t.recent_ranges.back().t;
  while (!t.recent_ranges.empty() &&
         t.recent_ranges.front().t < newest - s_to_utime(params_.epoch_window_s))
    t.recent_ranges.pop_front();
  // The newest range of each anchor.
  std::map<int, double> latest;
  for (const auto& m : t.recent_ranges) latest[m.anchor] = m.value;
  const bool planar = planar_for(tag_id);
  const int needed = planar ? 3 : 4;
  // As ips-uwb-twr: for the first second of waiting (and two epochs) one range more than a fix
  // needs, where the site has it, so that one NLOS range shows in the residual and is left out;
  // from the bare minimum nothing tells a 1.3 m long range, and the start would be that far off
  // with the geometry's small sigma. A running track's check (check_against_ranges) always
  // needs the spare range.
  if (!t.initialised && t.waiting_since == 0) t.waiting_since = t.recent_ranges.front().t;
  int required = needed, enabled_uwb_anchors = 0;
  for (const auto& a : site_->anchors) enabled_uwb_anchors += a.enabled && a.kind == "uwb";
  if (t.initialised || newest - t.waiting_since <
                           std::max<utime_t>(1'000'000, 2 * s_to_utime(params_.epoch_window_s)))
    required = std::min(needed + 1, enabled_uwb_anchors);
  if (static_cast<int>(latest.size()) < std::max(needed, required)) return std::nullopt;
  std::vector<RangeObservation> obs;
  for (const auto& [a, r] : latest) obs.push_back({site_->anchors[static_cast<size_t>(a)].position, r});
  MultilaterationOptions o;
  o.fixed_height = planar;
  o.height_m = planar ? tag_height(tag_id) : std::numeric_limits<double>::quiet_NaN();
  const double max_residual = 3.0 * params_.range_sigma_m + 0.2;
  const MultilaterationResult fix =
      multilaterate_dropping_one(obs, o, MultilaterationSolver::kLevenbergMarquardt, max_residual);
  if (!fix.ok) return std::nullopt;
  // The residual left (a consistent set still has some) widens the start as the noise does; a
  // start no spare range could check may hold an NLOS range of a metre or more.
  RangeFix out;
  out.t = newest;
  out.position = fix.position;
  out.checked = static_cast<int>(obs.size()) > needed;
  out.sigma_m = std::max(params_.range_sigma_m,
                         std::sqrt(std::max(0.0, fix.covariance_unit.trace())) *
                             std::max(params_.range_sigma_m, fix.residual_rms_m));
  if (!out.checked) out.sigma_m = std::max(out.sigma_m, uwb_twr::kUncheckedStartSigmaM);
  return out;
}

void FuseEstimator::try_start_from_ranges(const std::string& tag_id, Track& t) {
  if (const auto fix = fix_from_ranges(tag_id, t))
    start(tag_id, t, fix->t, fix->position, fix->sigma_m);
}

void FuseEstimator::check_against_ranges(const std::string& tag_id, Track& t) {
  // A running track that gates ranges while the ranges agree among themselves on a place the
  // track is not has lost the tag: the tag jumped (a simulator or a tag restarted), or the track
  // was started wrong (a hosted AoA tracker's first fix) and the gate keeps out the ranges that
  // would bring it back. Widening step by step (count_absolute) took seconds of confident
  // estimates metres off. So, at most every kLostCheckS while some ranges are gated: a
  // multilateration of the last epoch's ranges (with a spare range, its residual checked as a
  // start's is); kLostChecks of them within kFarFixSpan far outside the track's and the fix's
  // uncertainty, none agreeing with the track in between, and the track starts afresh at the fix
  // (`lost_restarts`, HEALTH). Until then the poses published hold the far fix in their
  // covariance (maybe_publish, `poses_doubted`).
  // A start from a prior (the site's start pose, a dead-reckoning position) is checked the same
  // way by the first such fix, gated or not: one that disagrees refutes the prior at once (a
  // process restarted mid-walk), one that agrees confirms it; unpublished until then
  // (maybe_publish).
  constexpr double kLostCheckS = 0.2;
  constexpr int kLostChecks = 3;
  constexpr double kChi2 = 13.8;     // 2 degrees of freedom, 99.9 %
  constexpr double kMinJumpM = 0.5;  // never for less: the ranges of a moving tag spread so
  if ((t.gated_since_check == 0 && !t.prior_unchecked) || t.recent_ranges.empty() ||
      t.recent_ranges.back().t - t.last_lost_check < s_to_utime(kLostCheckS))
    return;
  const auto fix = fix_from_ranges(tag_id, t);
  if (t.prior_unchecked && (!fix || !fix->checked)) return;  // at the next range again
  t.last_lost_check = t.recent_ranges.back().t;
  t.gated_since_check = 0;
  // No consistent fix (the ranges of the window disagree, or no spare range): neither for the
  // track nor against it, so a count of far fixes stands. After a jump the ranges of an epoch
  // often disagree (some from before the jump, offsets learned against the lost track), and
  // starting the count again at each of those kept the track metres off for 2 s.
  if (!fix || !fix->checked) return;
  t.last_checked_fix = fix->t;
  const FuseFilter& f = t.state.filter;
  const Eigen::Vector2d d = (fix->position - f.x.head<3>()).head<2>();
  const double var = f.P.topLeftCorner<2, 2>().trace() + 2.0 * fix->sigma_m * fix->sigma_m;
  const bool far = d.norm() >= kMinJumpM && d.squaredNorm() >= kChi2 * var;
  if (t.prior_unchecked) {
    // The ranges taken meanwhile may have pulled the track part of the way, its covariance
    // shrinking as if the prior had been right: unless it is within the fix's own noise, the
    // track starts afresh at the fix (refuted, and said, when also far by the test above).
    t.prior_unchecked = false;
    if (d.norm() <= fix->sigma_m) return;  // confirmed
    if (far) ++stats_.prior_refuted;
  } else {
    if (!far) {
      t.lost_checks = 0;
      return;
    }
    // kLostChecks far fixes within kFarFixSpan, none agreeing in between.
    if (t.lost_checks > 0 && fix->t - t.last_far_fix > kFarFixSpan) t.lost_checks = 0;
    t.last_far_fix = fix->t;
    t.far_fix_offset = d;
    if (++t.lost_checks < kLostChecks) return;
    ++stats_.lost_restarts;
    char text[200];
    std::snprintf(text, sizeof text,
                  "track %.1f m from where its ranges agree the tag is, gating them: restarted "
                  "there",
                  d.norm());
    last_lost_ = printable(tag_id) + ": " + text;
  }
  start(tag_id, t, fix->t, fix->position, fix->sigma_m);  // its next pose flagged REINITIALISED
}

void FuseEstimator::count_absolute(Snapshot& s, utime_t t, bool accepted, bool live,
                                   bool widen) {
  // A start from a prior that the first absolute measurements gate, kPriorRefuted in a row: the
  // tag is not where the prior says (a process restarted mid-walk takes the site's start pose, or
  // a module's dead-reckoning position, for where the tag is now). add() then starts the track
  // afresh from the measurements (as a tag without a prior starts), instead of a start sigma
  // around a position metres off, widened step by step.
  constexpr int kPriorRefuted = 4;
  if (!accepted) s.accepted_in_row = 0;
  if (accepted) {
    s.last_absolute = t;
    s.last_horizontal = t;
    s.rejections = 0;
    ++s.accepted_in_row;
    s.prior_only = false;
  } else if (++s.rejections >= kPriorRefuted && s.prior_only) {
    s.prior_refuted = true;
  } else if (s.rejections >= params_.reinit_after_rejections && widen) {
    // Gated again and again: the track has lost the tag. Widen it so that the ranges are taken
    // again (a re-acquisition, not a jump past the gate of one range). Not for ranges that
    // check_against_ranges can judge (a widened track would pass its test).
    FuseFilter& f = s.filter;
    for (int i = 0; i < (f.planar ? 2 : 3); ++i) f.P(i, i) += 1.0;
    s.rejections = 0;
    if (live) ++stats_.restarts;
  }
}

void FuseEstimator::on_hosted_fix(const pose_t& m) {
  // The epoch went through on_tdoa_epoch / on_aoa_epoch first, so the track exists unless the tag
  // was refused (too many tags).
  const auto it = tracks_.find(m.tag_id);
  if (it == tracks_.end() || it->second.initialised) return;
  const bool horizontal_only = (m.status & pose_t::STATUS_2D) != 0;
  const auto cov = pose_covariance(m, horizontal_only);
  if (!finite_position(m) || !cov) return;
  const Eigen::Vector3d p(m.position[0], m.position[1], m.position[2]);
  start(m.tag_id, it->second, m.utime, p, std::sqrt(std::max(cov->trace() / 3.0, 1e-6)));
  ++stats_.hosted_starts;
}

}  // namespace ips::fusion
