// FuseEstimator's history: measurements are fused in time order as they arrive; a late one (up
// to max_delay_s behind the tag's newest) rolls the track back to the snapshot before it and
// the later ones are fused again.
#include "fusion/fuse_estimator.hpp"

#include <algorithm>
#include <utility>

namespace ips::fusion {

namespace {
constexpr size_t kMaxHistory = 10000;  // per tag, whatever max_delay_s allows
}  // namespace

void FuseEstimator::add(const std::string& tag_id, Track& t, Measurement m) {
  if (!t.initialised) {
    ++stats_.waiting_start;
    return;
  }
  const utime_t from = m.kind == Measurement::Kind::kDisplacement ? m.t0 : m.t;
  const utime_t window = s_to_utime(params_.max_delay_s);
  if (from < t.base.t) {  // before anything the track can roll back to
    ++stats_.dropped_late;
    return;
  }
  t.newest = std::max(t.newest, m.t);
  if (m.kind != Measurement::Kind::kDisplacement && m.kind != Measurement::Kind::kFrame)
    t.absolute_seen = true;
  // In time order into the history.
  const size_t index = t.history.upper_bound(m.t, [](const Measurement& h) { return h.t; });
  t.history.insert(index, std::move(m));
  if (from >= t.state.t && index + 1 == t.history.size()) {
    apply(t, t.state, t.history.back(), true);
    t.snapshots.push_back(t.state);
  } else {
    // Late, or a displacement reaching back over fused messages: from the last snapshot at or
    // before `from`, fuse again in order.
    ++stats_.rollbacks;
    size_t k = 0;  // entries [0, k) keep their snapshots
    while (k < t.snapshots.size() && k < t.history.size() && t.history[k].t <= from &&
           k != index)
      ++k;
    Snapshot s = k == 0 ? t.base : t.snapshots[k - 1];
    t.snapshots.truncate(k);
    for (size_t j = k; j < t.history.size(); ++j) {
      apply(t, s, t.history[j], j == index);
      t.snapshots.push_back(s);
    }
    t.state = s;
  }
  if (t.state.prior_refuted) {  // the track is started afresh from the measurements to come
    ++stats_.prior_refuted;
    restart_track(tag_id);
    return;
  }
  // Forget what no late message can reach any more (keeping the base to roll back to).
  while (t.history.size() > 1 &&
         (t.history.front().t < t.newest - window || t.history.size() > kMaxHistory)) {
    t.base = t.snapshots.front();
    t.history.pop_front();
    t.snapshots.pop_front();
  }
  maybe_publish(tag_id, t);
}

void FuseEstimator::apply(Track& t, Snapshot& s, const Measurement& m, bool live) {
  predict(t, s, m.t);
  switch (m.kind) {
    case Measurement::Kind::kRange: apply_range(t, s, m, live); break;
    case Measurement::Kind::kTdoa: apply_tdoa(t, s, m, live); break;
    case Measurement::Kind::kAngles: apply_angles(t, s, m, live); break;
    case Measurement::Kind::kHeight: apply_height(t, s, m, live); break;
    case Measurement::Kind::kPosition: apply_position(t, s, m, live); break;
    case Measurement::Kind::kDisplacement: apply_displacement(t, m, live); break;
    case Measurement::Kind::kFrame: new_frame(s.filter); break;
  }
}

}  // namespace ips::fusion
