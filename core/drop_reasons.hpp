#pragma once
// Why an estimator's input gave no estimate, counted by reason: one fixed list for every
// estimator, so that HEALTH (live) and ips-replay's summary (offline) say the same thing in the
// same words ("dropped 12: 10 no site, 2 gated"). A plain array of counters: nothing allocates
// per message; only summary() builds a string.
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

namespace ips {

// Counts are of input messages, except where the text names another unit (an epoch, a fix).
enum class DropReason : uint8_t {
  kNoSite,                   // no site yet (neither --site nor a SITE message)
  kNoAnchorsOfKind,          // the site has no enabled anchor of the estimator's kind at all
  kUnknownAnchor,            // an anchor the site does not have (or has disabled, or of another kind)
  kInvalid,                  // NaN/inf or absurd value, implausible time stamp, empty id
  kLate,                     // late or out of order beyond the reorder tolerance
  kTimeJump,                 // a stamp far from its sender's timeline, refuted (core/time_guard.hpp)
  kDuplicate,                // a second report of the same thing
  kGap,                      // after a gap too long to integrate over
  kTooManyTags,              // a new tag while max_tags are tracked
  kOutsideCalibration,       // beyond a calibration's valid interval
  kNoReference,              // no reference barometer heard yet
  kStaleReference,           // the reference's newest reading too old
  kReferenceWithoutHeight,   // a reference barometer with no known height
  kOtherSource,              // a second dead-reckoning source for one tag
  kUnmatchedSync,            // a TDoA sync reception without the master's record, or not from it
  kInitialising,             // taken while still aligning / initialising: no estimate yet
  kGated,                    // an outlier rejected by the innovation gate or a plausibility test
  kNoClock,                  // a reception at an anchor whose clock is not synchronised yet
  kTooFewAnchors,            // an epoch heard by too few anchors for a fix
  kNoFix,                    // a solver found no position, or one with too poor geometry
  kSuperseded,               // a pose whose raw measurements the estimator fuses itself
  kSurveyRange,              // an anchor-to-anchor range (survey input), not a tag's
  // A sample of a stream (IMU) that came after a later one, within the reorder tolerance: the
  // next sample's interval covers its own (a LAN reorders datagrams now and then).
  kReordered,
  kCount
};

// Plain words for a reason, as summaries print them.
constexpr std::string_view drop_reason_text(DropReason r) {
  switch (r) {
    case DropReason::kNoSite: return "no site";
    case DropReason::kNoAnchorsOfKind: return "no anchors of its kind in the site";
    case DropReason::kUnknownAnchor: return "unknown anchor";
    case DropReason::kInvalid: return "invalid";
    case DropReason::kLate: return "late or out of order";
    case DropReason::kTimeJump: return "time stamp far from its sender's";
    case DropReason::kDuplicate: return "duplicate";
    case DropReason::kGap: return "after a gap";
    case DropReason::kTooManyTags: return "beyond max_tags";
    case DropReason::kOutsideCalibration: return "outside calibration";
    case DropReason::kNoReference: return "no reference barometer yet";
    case DropReason::kStaleReference: return "reference too old";
    case DropReason::kReferenceWithoutHeight: return "reference without height";
    case DropReason::kOtherSource: return "second dead-reckoning source";
    case DropReason::kUnmatchedSync: return "sync unmatched or not from the master";
    case DropReason::kInitialising: return "still aligning/initialising";
    case DropReason::kGated: return "gated";
    case DropReason::kNoClock: return "anchor clock not synchronised";
    case DropReason::kTooFewAnchors: return "epoch with too few anchors";
    case DropReason::kNoFix: return "no fix";
    case DropReason::kSuperseded: return "superseded by fused measurements";
    case DropReason::kSurveyRange: return "anchor-to-anchor range";
    case DropReason::kReordered: return "reordered sample";
    case DropReason::kCount: break;
  }
  return "?";
}

// Routine reasons happen in small numbers in a healthy system (outliers, start-up): counted in
// HEALTH's drops but not marking the process degraded. The others point at a fault in the input
// or the configuration.
constexpr bool drop_reason_is_routine(DropReason r) {
  switch (r) {
    case DropReason::kInitialising:
    case DropReason::kGated:
    case DropReason::kDuplicate:
    case DropReason::kNoClock:
    case DropReason::kTooFewAnchors:
    case DropReason::kNoFix:
    case DropReason::kSuperseded:
    case DropReason::kSurveyRange:
    case DropReason::kReordered: return true;
    default: return false;
  }
}

// A stream's sample (IMU) at or before the newest one taken, counted by how far out of turn it
// came (times in µs): at the newest's time a duplicate (a LAN repeats datagrams); before it within
// `tolerance` reordered on the way (kReordered, routine: the next sample's interval covers it);
// further back late (kLate, a fault).
inline void count_out_of_turn(int64_t utime, int64_t newest, int64_t tolerance, int64_t& repeated,
                              int64_t& reordered, int64_t& late) {
  if (utime == newest) ++repeated;
  else if (newest - utime <= tolerance) ++reordered;
  else ++late;
}

class DropReasons {
 public:
  static constexpr size_t kNumReasons = static_cast<size_t>(DropReason::kCount);

  void add(DropReason r, int64_t n = 1) {
    if (r < DropReason::kCount) counts_[static_cast<size_t>(r)] += n;
  }
  int64_t count(DropReason r) const {
    return r < DropReason::kCount ? counts_[static_cast<size_t>(r)] : 0;
  }
  int64_t total() const {
    int64_t n = 0;
    for (int64_t c : counts_) n += c;
    return n;
  }
  // The drops for non-routine reasons.
  int64_t faults() const {
    int64_t n = 0;
    for (size_t i = 0; i < kNumReasons; ++i)
      if (!drop_reason_is_routine(static_cast<DropReason>(i))) n += counts_[i];
    return n;
  }
  // The reason with the largest count (the first in the list on a tie); kCount when none.
  DropReason dominant() const {
    size_t best = kNumReasons;
    for (size_t i = 0; i < kNumReasons; ++i)
      if (counts_[i] > 0 && (best == kNumReasons || counts_[i] > counts_[best])) best = i;
    return static_cast<DropReason>(best);
  }
  DropReasons& operator+=(const DropReasons& o) {
    for (size_t i = 0; i < kNumReasons; ++i) counts_[i] += o.counts_[i];
    return *this;
  }
  DropReasons& operator-=(const DropReasons& o) {
    for (size_t i = 0; i < kNumReasons; ++i) counts_[i] -= o.counts_[i];
    return *this;
  }
  // Per reason, the smaller count of the two.
  static DropReasons min(const DropReasons& a, const DropReasons& b) {
    DropReasons m;
    for (size_t i = 0; i < kNumReasons; ++i) m.counts_[i] = std::min(a.counts_[i], b.counts_[i]);
    return m;
  }
  bool operator==(const DropReasons&) const = default;

  // "10 no site, 2 gated": the reasons with a count, largest first (list order on a tie), at most
  // `max_reasons` of them and then "and N more"; "" when nothing was dropped.
  std::string summary(size_t max_reasons = kNumReasons) const {
    std::array<size_t, kNumReasons> order{};
    size_t n = 0;
    for (size_t i = 0; i < kNumReasons; ++i)
      if (counts_[i] > 0) order[n++] = i;
    std::stable_sort(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(n),
                     [this](size_t a, size_t b) { return counts_[a] > counts_[b]; });
    std::string s;
    for (size_t k = 0; k < n && k < max_reasons; ++k) {
      if (!s.empty()) s += ", ";
      s += std::to_string(counts_[order[k]]);
      s += ' ';
      s += drop_reason_text(static_cast<DropReason>(order[k]));
    }
    if (n > max_reasons) s += ", and " + std::to_string(n - max_reasons) + " more";
    return s;
  }
  // "dropped 12: 10 no site, 2 gated"; "" when nothing was dropped.
  std::string text(size_t max_reasons = kNumReasons) const {
    const int64_t n = total();
    if (n == 0) return "";
    return "dropped " + std::to_string(n) + ": " + summary(max_reasons);
  }

 private:
  std::array<int64_t, kNumReasons> counts_{};
};

// A live process's report of its estimator's drops in HEALTH. Call report() from a timer (1 Hz:
// that is the rate limit): the new drops are added to the node's drop counter, and when drops for
// a non-routine reason were added the node reports "dropped N: <reasons>" as its error (the
// process is degraded for a while); routine ones are counted without degrading it. `NodeT` is
// ips::Node (or anything with counters().drops and report_error(text)); a template, so that
// estimator cores can include this header without the node runtime.
class DropHealth {
 public:
  // `detail`, when given, follows the counts ("...; no reference barometer heard yet: ...").
  template <class NodeT>
  void report(NodeT& node, const DropReasons& now, const std::string& detail = {}) {
    const int64_t added = now.total() - reported_.total();
    if (added <= 0) return;
    node.counters().drops += added;
    const bool fault = now.faults() > reported_.faults();
    reported_ = now;
    if (fault) node.report_error(detail.empty() ? now.text() : now.text() + "; " + detail);
  }

 private:
  DropReasons reported_;
};

}  // namespace ips
