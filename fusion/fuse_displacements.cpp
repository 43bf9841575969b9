// Dead-reckoning displacements as the motion model (001's INS): a foot-INS module's positions
// (INS_MODULE), ips-ins's (POSE_INS) or ips-pdr's steps (STEP), one source per tag, rotated by the
// estimated heading bias; between them constant velocity, turned by the tag's gyro
// (fuse_gyro.cpp).
#include "fusion/fuse_estimator.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <optional>
#include <string>
#include <utility>

#include "core/geometry.hpp"
#include "core/text_escape.hpp"
#include "fusion/fuse_inputs.hpp"

namespace ips::fusion {

namespace {
// A new frame's displacements held back (predict) until they add up to this, where absolute
// measurements within kFrameRecent move the track.
constexpr double kFrameBaselineM = 1.0;
constexpr utime_t kFrameRecent = 1'000'000;
// ... and opened only where the last of them, this recent, was taken (not gated): a track whose
// measurements have paused or disagree with it (a tag that jumped) may be about to be corrected.
constexpr utime_t kFrameOpen = 300'000;
// ... and after this many taken in a row (one accepted between gated ones opened windows on a
// track the ranges were still pulling back to a jumped tag).
constexpr int kFrameOpenAccepted = 4;
// Windows measured (measure_frame: no rotation of the displacements', or a rotation the prior
// refutes that the next window has not confirmed) before the prior is taken instead.
constexpr int kFrameTries = 4;
// How long a new frame waits, its displacements held back, for measurements to open its window
// where they have paused or disagree with the track, before the prior is taken.
constexpr utime_t kFrameWait = 2'000'000;
// After a window whose track was corrected meanwhile, how long before the next may open.
constexpr utime_t kFrameSettle = 1'000'000;

const char* displacement_channel(DisplacementSource s) {
  switch (s) {
    case DisplacementSource::kInsModule: return "INS_MODULE";
    case DisplacementSource::kPoseIns: return "POSE_INS";
    case DisplacementSource::kStep: return "STEP";
    case DisplacementSource::kAuto:
    case DisplacementSource::kNone: break;
  }
  return "none";
}

// "T1: using INS_MODULE for displacements, ignoring STEP" (count 0: the note when it starts), or
// with the count, "..., ignored 60 STEP"; a configured `none` uses no source.
std::string ignored_text(const std::string& tag_id, DisplacementSource used,
                         DisplacementSource ignored, int64_t count = 0) {
  std::string s = printable(tag_id) + ": ";
  s += used == DisplacementSource::kNone
           ? std::string("no displacements (estimators.fuse.displacement: none)")
           : std::string("using ") + displacement_channel(used) + " for displacements";
  s += count == 0 ? std::string(", ignoring ")
                  : ", ignored " + std::to_string(count) + " ";
  return s + displacement_channel(ignored);
}
}  // namespace

bool FuseEstimator::accept_displacement(const std::string& tag_id, Track& t,
                                        DisplacementSource src) {
  if (params_.displacement == DisplacementSource::kAuto) {
    if (t.displacement == DisplacementSource::kNone) t.displacement = src;
  } else {
    t.displacement = params_.displacement;
  }
  if (t.displacement == src) return true;
  // One source moves a tag (a second would count the same walk twice): the others are left
  // unused on purpose, which is no fault of the input. Said once per tag and source.
  ++stats_.ignored_other_source;
  IgnoredSource& ignored = ignored_[{tag_id, src}];
  if (ignored.count++ == 0) {
    ignored.used = t.displacement;
    if (note_sink_) note_sink_(ignored_text(tag_id, ignored.used, src));
  }
  return false;
}

std::string FuseEstimator::run_notes() const {
  std::string s;
  auto add = [&s](const std::string& text) { s += (s.empty() ? "" : "; ") + text; };
  for (const auto& [key, ignored] : ignored_)
    add(ignored_text(key.first, ignored.used, key.second, ignored.count));
  // Estimates that were off for a while, as HEALTH says them live: how often, and the last.
  auto restarts = [&add](int64_t n, const char* what, const std::string& last) {
    if (n > 0) add(std::to_string(n) + " " + what + (last.empty() ? "" : ", the last: " + last));
  };
  restarts(stats_.gap_restarts, "track(s) restarted after a gap", last_gap_);
  restarts(stats_.prior_refuted, "start(s) from a prior refuted by the first measurements", "");
  restarts(stats_.lost_restarts, "track(s) that had lost their tag restarted", last_lost_);
  if (stats_.poses_doubted > 0)
    add(std::to_string(stats_.poses_doubted) +
        " pose(s) published while a fix of the ranges disagreed, their covariance widened to "
        "hold it");
  restarts(stats_.source_restarts, "dead-reckoning source restart(s), their jump not used",
           last_source_restart_);
  return s;
}

void FuseEstimator::count_dr_out_of_turn(const Track& t, utime_t utime) {
  count_out_of_turn(utime, t.last_dr_t, s_to_utime(params_.max_delay_s), stats_.dropped_dr_repeated,
                    stats_.dropped_dr_reordered, stats_.dropped_dr_late);
}

void FuseEstimator::on_dead_reckoning(const pose_t& m, DisplacementSource src, uint32_t bit) {
  Track* t = track_for(m.tag_id, m.utime, [this, m, src, bit] { on_dead_reckoning(m, src, bit); });
  if (!t) return;
  if (!finite_position(m)) {
    ++stats_.dropped_invalid;
    return;
  }
  if (!accept_displacement(m.tag_id, *t, src)) return;
  const Eigen::Vector3d p(m.position[0], m.position[1], m.position[2]);
  if (!t->have_last_dr || m.utime <= t->last_dr_t) {
    if (t->have_last_dr) {  // not after the previous one: a copy, reordered, or late
      count_dr_out_of_turn(*t, m.utime);
      return;
    }
    t->have_last_dr = true;
    t->last_dr_t = m.utime;
    t->last_dr_position = p;
    // Its first position starts the track when nothing else has (001: the module starts where
    // the walk does); after a gap, only a track that never had a fix of the site's frame.
    if (!t->initialised && (!t->ever_started || !t->absolute_seen))
      start(m.tag_id, *t, m.utime, p, params_.start_sigma_m, true);
    return;
  }
  Measurement d;
  d.kind = Measurement::Kind::kDisplacement;
  d.t0 = t->last_dr_t;
  d.t = m.utime;
  d.vec = p - t->last_dr_position;
  d.source = bit;
  t->last_dr_t = m.utime;
  t->last_dr_position = p;
  if (t->initialised && source_restarted(m.tag_id, *t, d, src)) {
    // Re-anchored at p (above); its frame is new too, its heading unknown again (a module
    // restarts with its initial heading error, not with the drift it had reached).
    Measurement frame;
    frame.kind = Measurement::Kind::kFrame;
    frame.t = m.utime;
    frame.source = bit;
    add(m.tag_id, *t, std::move(frame));
    return;
  }
  t->dr_bit = bit;
  if (t->initialised) add(m.tag_id, *t, std::move(d));
  else if (!t->ever_started || !t->absolute_seen) start(m.tag_id, *t, m.utime, p, params_.start_sigma_m, true);
}

bool FuseEstimator::source_restarted(const std::string& tag_id, const Track& t,
                                     const Measurement& d, DisplacementSource src) {
  // A source that restarts (a foot-INS module rebooted, a simulator restarted with its module)
  // reports positions from a new origin: the step from its last position before to its first
  // after is no displacement of the tag, and taken as one it threw the track metres off, and the
  // heading bias with it (issue 26's soak). A displacement the track's own motion cannot explain
  // is taken for that: further than the track's speed carries it in the time, by more than 1 m
  // and 3 sigma of what the speed and the acceleration noise allow. Only the length is judged,
  // not the direction (a walker turns a corner between two of a module's 2 Hz positions).
  // Nothing of that displacement is used; the source's positions are taken from the new origin
  // on (`source_restarts`, said in HEALTH). Missing one displacement costs little: the ranges
  // and the constant-velocity model carry the track over it.
  constexpr double kMinExcessM = 1.0;
  const FuseFilter& f = t.state.filter;
  const double dt = utime_to_s(d.t - d.t0);
  const double moved = d.vec.head<2>().norm();
  const double speed = f.x.segment<2>(kVel).norm();
  const double speed_sigma = std::sqrt(std::max(0.0, f.P(kVel, kVel) + f.P(kVel + 1, kVel + 1)));
  const double sigma = speed_sigma * dt + std::sqrt(params_.accel_psd * dt * dt * dt / 3.0) +
                       params_.displacement_sigma(moved);
  const double excess = moved - speed * dt;
  if (excess <= std::max(kMinExcessM, 3.0 * sigma)) return false;
  ++stats_.source_restarts;
  char text[240];
  std::snprintf(text, sizeof text,
                "%s moved %.1f m in %.1f s, the track %.1f m: taken for the source restarting "
                "(a new origin), not a displacement",
                displacement_channel(src), moved, dt, speed * dt);
  last_source_restart_ = printable(tag_id) + ": " + text;
  return true;
}

void FuseEstimator::on_ins_module(const pose_t& m) {
  on_dead_reckoning(m, DisplacementSource::kInsModule, kSrcInsModule);
}

void FuseEstimator::on_pose_ins(const pose_t& m) {
  on_dead_reckoning(m, DisplacementSource::kPoseIns, kSrcPoseIns);
}

void FuseEstimator::on_step(const step_t& m) {
  Track* t = track_for(m.tag_id, m.utime, [this, m] { on_step(m); });
  if (!t) return;
  if (!std::isfinite(m.length_m) || m.length_m < 0 || m.length_m > 5 ||
      !m.heading_known || !std::isfinite(m.heading_rad)) {
    ++stats_.dropped_invalid;
    return;
  }
  if (!accept_displacement(m.tag_id, *t, DisplacementSource::kStep)) return;
  // A step covers the time since the previous one (at most 2 s: a first step, or after a stop).
  const utime_t longest = s_to_utime(2.0);
  const utime_t t0 = t->have_last_dr && m.utime > t->last_dr_t && m.utime - t->last_dr_t < longest
                         ? t->last_dr_t
                         : m.utime - (std::isfinite(m.cadence_hz) && m.cadence_hz > 0.3
                                          ? s_to_utime(1.0 / m.cadence_hz)
                                          : s_to_utime(0.5));
  if (t->have_last_dr && m.utime <= t->last_dr_t) {  // a copy, reordered, or late
    count_dr_out_of_turn(*t, m.utime);
    return;
  }
  t->have_last_dr = true;
  t->last_dr_t = m.utime;
  if (!t->initialised) {  // a step says nothing of where the tag is
    ++stats_.waiting_start;
    return;
  }
  Measurement d;
  d.kind = Measurement::Kind::kDisplacement;
  d.t0 = t0;
  d.t = m.utime;
  d.vec = Eigen::Vector3d(m.length_m * std::cos(m.heading_rad),
                          m.length_m * std::sin(m.heading_rad), 0.0);
  d.source = kSrcStep;
  t->dr_bit = kSrcStep;
  add(m.tag_id, *t, std::move(d));
}

void FuseEstimator::predict(const Track& t, Snapshot& s, utime_t to) const {
  const double psi_walk = std::pow(deg_to_rad(params_.heading_bias_walk_deg_per_sqrt_s), 2);
  utime_t cursor = s.t;
  if (to <= cursor) return;
  // Constant velocity from a to b, turned by the gyro's turn meanwhile when there is one.
  // A displacement's velocity is its average, the direction it had in its middle: the turn is
  // counted from there.
  auto cv = [&](utime_t a, utime_t b) {
    const utime_t from = std::min(s.velocity_t, a);
    std::optional<double> mid, end;
    if (params_.gyro_turns) {
      mid = t.gyro.turn(from, a + (b - a) / 2);
      end = t.gyro.turn(from, b);
    }
    s.filter.predict_cv(utime_to_s(b - a), params_.accel_psd, psi_walk,
                        mid && end ? *mid : 0.0, mid && end ? *end : 0.0);
    s.velocity_t = b;
  };
  // The history is in time order: what ends by the cursor is skipped without a look.
  const size_t first = t.history.upper_bound(cursor, [](const Measurement& h) { return h.t; });
  for (size_t i = first; i < t.history.size(); ++i) {
    const Measurement& d = t.history[i];
    if (d.kind != Measurement::Kind::kDisplacement || d.t <= cursor || d.t0 >= to) continue;
    const utime_t a = std::max(d.t0, cursor), b = std::min(d.t, to);
    if (b <= a) continue;
    if (a > cursor) cv(cursor, a);
    const double fraction = static_cast<double>(b - a) / static_cast<double>(d.t - d.t0);
    const Eigen::Vector3d part = fraction * d.vec;
    if (!s.filter.frame_aligned) {
      // A new frame (a track's start, a source's restart). Its rotation is known only to
      // heading_bias_sigma_deg, but a module's frame is wherever it was switched on and drifts
      // on: a restarted ips-fuse met one 131 deg from the site's (issue 26's soak), took its
      // displacements pointing the wrong way and was 0.45 m off saying 0.1 m. So where absolute
      // horizontal measurements were moving the track when the frame's first displacement
      // began, its displacements are held back until they add up to kFrameBaselineM, the track
      // moving on those measurements at constant velocity meanwhile, as it did before; then the
      // two paths' directions measure the rotation (measure_frame). A track the frame started
      // (from the module's first position: 001's corridor, where one or two anchors cannot carry
      // it alone) takes its displacements at once with the prior; one whose measurements have
      // paused or disagree with it waits for them (below).
      FuseFilter& f = s.filter;
      if (f.frame_began == 0) f.frame_began = a;
      const bool recent =
          s.last_horizontal != 0 &&
          (f.frame_window ? a - s.last_horizontal <= kFrameRecent
                          : a >= f.frame_open_after && a - s.last_horizontal <= kFrameOpen &&
                                s.accepted_in_row >= kFrameOpenAccepted);
      if (recent && !f.frame_window) f.open_frame_window();
      if (recent) {
        cv(a, b);
        cursor = b;
        f.frame_dr += part.head<2>();
        if (f.frame_dr.norm() >= kFrameBaselineM) {
          const FrameCheck res = measure_frame(f);
          if (res == FrameCheck::kConfirm && ++f.frame_tries < kFrameTries) {
            f.open_frame_window();
          } else if (res == FrameCheck::kAgain && ++f.frame_tries < kFrameTries) {
            // The track was being corrected (a jumped tag re-acquired): the next window opens
            // kFrameSettle later, by the same rule as the first, the displacements used untied
            // meanwhile. Opened at once, its constant velocity carried the correction's speed on
            // (the soak's faults 137 and 168: 3 m off for 0.5 s).
            f.frame_window = false;
            f.frame_open_after = b + kFrameSettle;
          } else {
            f.frame_window = false;
            f.frame_aligned = true;
          }
        }
        continue;
      }
      // Measurements paused or disagreeing: the tag may have jumped (a simulator restarted with
      // its module, the soak's fault 131), the track about to be corrected. The displacements
      // taken at once with the prior coupled the heading bias to the ranges' re-acquisition,
      // which drove it 2.3 rad from the prior and kept the track 0.5 to 0.9 m off for 2.5 s.
      // So the frame waits for them up to kFrameWait (longer after a window measured), its
      // displacements moving the track untied from the heading bias meanwhile.
      if (s.last_horizontal != 0 && a - f.frame_began < kFrameWait * (1 + f.frame_tries)) {
        f.frame_window = false;
        s.filter.predict_displacement_untied(
            part, utime_to_s(b - a), std::sqrt(fraction) * params_.displacement_sigma(d.vec.norm()));
        s.velocity_t = d.t0 + (d.t - d.t0) / 2;
        cursor = b;
        continue;
      }
      f.frame_window = false;
      f.frame_aligned = true;
    }
    // The whole displacement's variance, shared out in proportion to time, so that splitting it
    // between other messages adds up to the same.
    const double sigma = std::sqrt(fraction) * params_.displacement_sigma(d.vec.norm());
    s.filter.predict_displacement(part, utime_to_s(b - a), sigma, psi_walk);
    s.velocity_t = d.t0 + (d.t - d.t0) / 2;
    cursor = b;
  }
  if (cursor < to) cv(cursor, to);
  s.t = to;
}

void FuseEstimator::new_frame(FuseFilter& f) const {
  // As start() sets it: the bias unknown within heading_bias_sigma_deg, uncorrelated.
  const double bias_sigma = deg_to_rad(params_.heading_bias_sigma_deg);
  f.set_heading_bias(0.0, std::max(bias_sigma * bias_sigma, 1e-12));
  f.frame_aligned = false;
  f.frame_window = false;
  f.frame_tries = 0;
  f.frame_began = 0;
  f.frame_open_after = 0;
  f.frame_pending = false;
}

FuseEstimator::FrameCheck FuseEstimator::measure_frame(FuseFilter& f) const {
  // The track's path over the window (its chord, from absolute measurements) against the
  // displacements' sum: the rotation psi between them, with a variance from the two ends'
  // position covariances across the chord (their correlation, which makes the chord better known,
  // left out: it errs wide) and the displacements' own noise over their length. A rotation keeps
  // lengths: a chord whose length differs from the displacements' by more than kLengthSigmas
  // (the same covariances along it) is no rotation of them, but a track corrected meanwhile (a
  // tag that jumped, a simulator restarted: the soak's second run measured 2.9 rad from such a
  // window), and a new window is measured. Combined with the prior where the two agree within 3
  // sigma; further off the prior is what is wrong, and the measurement replaces it. Where the path
  // says too little (the angle's sigma over kMaxSigmaRad) the prior stands.
  constexpr double kMaxSigmaRad = 20.0 * std::numbers::pi / 180.0;
  constexpr double kLengthSigmas = 2.0;
  const Eigen::Vector2d chord = f.x.head<2>() - f.frame_from;
  const double length = chord.norm(), dr_length = f.frame_dr.norm();
  if (!(length > 0) || !(dr_length > 0)) return FrameCheck::kAgain;
  const Eigen::Matrix2d ends = f.P.block<2, 2>(0, 0) + f.frame_from_cov;
  const Eigen::Vector2d along = chord / length;
  const Eigen::Vector2d across(-along.y(), along.x());
  const double dr_sigma = params_.displacement_sigma(dr_length);
  const double length_var = along.dot(ends * along) + dr_sigma * dr_sigma;
  const double var =
      across.dot(ends * across) / (length * length) + dr_sigma * dr_sigma / (dr_length * dr_length);
  if (!(var <= kMaxSigmaRad * kMaxSigmaRad)) return FrameCheck::kPriorStands;
  if (std::abs(length - dr_length) > kLengthSigmas * std::sqrt(length_var))
    return FrameCheck::kAgain;
  const double measured = wrap_angle(std::atan2(chord.y(), chord.x()) -
                                     std::atan2(f.frame_dr.y(), f.frame_dr.x()));
  // A measurement of psi alone, gated at 3 sigma.
  Mat<1, kStateSize> h = Mat<1, kStateSize>::Zero();
  h(kPsi) = 1.0;
  const double off_prior = wrap_angle(measured - f.x(kPsi));
  if (off_prior * off_prior <= 9.0 * (f.P(kPsi, kPsi) + var)) {
    scalar_update<kStateSize>(f.x, f.P, h, off_prior, var, 9.0);
    f.x(kPsi) = wrap_angle(f.x(kPsi));
    return FrameCheck::kMeasured;
  }
  // One that refutes the prior replaces it only when the next window agrees: a window that
  // spanned a correction of the track (a tag that jumped, its ranges re-acquiring it) can keep
  // the length of the displacements by chance and still point anywhere (replaying the soak's
  // evidence: 2.14 rad from a window opened while the ranges pulled the track 2 m).
  if (f.frame_pending) {
    const double apart = wrap_angle(measured - f.frame_pending_psi);
    if (apart * apart <= 9.0 * (var + f.frame_pending_var)) {
      // Both: the variance-weighted mean of the two.
      const double w = f.frame_pending_var / (f.frame_pending_var + var);
      f.set_heading_bias(wrap_angle(f.frame_pending_psi + w * apart),
                         f.frame_pending_var * var / (f.frame_pending_var + var));
      f.frame_pending = false;
      return FrameCheck::kMeasured;
    }
  }
  f.frame_pending = true;
  f.frame_pending_psi = measured;
  f.frame_pending_var = var;
  return FrameCheck::kConfirm;
}

void FuseEstimator::apply_displacement(Track& t, const Measurement& m, bool live) {
  // Its motion went into predict(); counted here.
  if (live) {
    ++stats_.displacements_used;
    t.sources |= m.source;
  }
}

}  // namespace ips::fusion
