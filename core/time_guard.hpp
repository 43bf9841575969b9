#pragma once
// Time plausibility at an estimator's inputs. A message's utime comes off an unauthenticated bus:
// one stamp a year ahead, taken as a tag's newest, made every real message after it "late" and
// stopped ips-fuse for the rest of a run. The guard sits in front of an estimator and keeps, per
// sender (a tag, an anchor, a device: one clock), the newest time it has accepted:
//  - a stamp within [newest - max_behind_s, newest + max_ahead_s] of the sender's newest, or
//    ahead of it but within max_ahead_s of the newest of all senders (a sender back from a
//    silence while others went on), is accepted and passed on;
//  - any other is a suspect: held back, not passed on, and never the reference for later ones;
//  - `confirm` suspects in a row, consistent with each other, while nothing of the sender's old
//    timeline arrives, re-anchor the sender on the new timeline (a driver restarted on a host
//    whose clock differs, a replay started again, a tag back after a long silence when it is the
//    only sender): they are released in order and counted as a re-anchoring, and the estimator
//    is told whether time went back (its state for that sender must start afresh);
//  - a message of the old timeline refutes the held suspects: they are discarded and counted.
// One bad stamp therefore costs nothing but its own message; a real jump costs the latency of
// `confirm` messages and nothing is lost. Pure and deterministic (message time only, no clock).
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "core/time.hpp"

namespace ips {

struct TimeGuardParams {
  double max_ahead_s = 0.5;   // ahead of the sender's (or everyone's) newest: a suspect beyond,
                              // plus twice the sender's usual interval (a 1 Hz anchor: 2.5 s)
  double max_behind_s = 2.0;  // behind the sender's newest: a suspect beyond (late ones within
                              // are the estimator's own business)
  int confirm = 3;            // consistent suspects in a row that re-anchor a sender
  size_t max_senders = 4096;  // senders remembered (ids come off the bus); beyond, stale ones go
};

struct TimeGuardStats {
  int64_t accepted = 0;
  int64_t held = 0;        // suspects held back (released later or discarded)
  int64_t released = 0;    // held suspects passed on after a re-anchoring
  int64_t discarded = 0;   // held suspects refuted by the sender's own timeline: dropped
  int64_t reanchors = 0;   // senders moved to a new timeline
  int64_t reanchors_back = 0;  // ... of them, back in time
};

class TimeGuard {
 public:
  enum class Verdict {
    kAccept,    // pass the message on
    kHeld,      // a suspect: the guard keeps `again` and calls it if the suspect is confirmed
    kReanchor,  // the sender moved to this message's timeline: call release() after resetting
                // what the estimator keeps of the sender when went_back(); then pass it on
  };

  TimeGuard() = default;
  explicit TimeGuard(const TimeGuardParams& p) : params_(p) {}
  void set_params(const TimeGuardParams& p) { params_ = p; }
  const TimeGuardParams& params() const { return params_; }

  // Checks `t` of a message from `sender`. For kHeld, `again` (which hands the same message to
  // the estimator again) is kept; for the others it is not used.
  template <class Again>
  Verdict check(const std::string& sender, utime_t t, Again&& again) {
    Sender* s = sender_for(sender);
    learn_interval(*s, t);
    const utime_t ahead = ahead_of(*s);
    const utime_t behind = s_to_utime(params_.max_behind_s);
    const bool agrees =
        s->suspects > 0 && t <= s->suspect_newest + ahead && t >= s->suspect_newest - behind;
    if (in_window(s, t)) {
      s->suspects = 0;
      s->newest = std::max(s->newest, t);
      newest_ = std::max(newest_, t);
      ++stats_.accepted;
      if (s->held.empty()) return Verdict::kAccept;
      if (!agrees) {  // refuted by the sender's own timeline
        stats_.discarded += static_cast<int64_t>(s->held.size());
        s->held.clear();
        return Verdict::kAccept;
      }
      // Within reach of everyone's now (another sender came back from the same silence first):
      // the suspects held are confirmed with it.
      went_back_ = false;
      releasing_.swap(s->held);
      s->held.clear();
      ++stats_.reanchors;
      return Verdict::kReanchor;
    }
    // A suspect: consistent with the suspects before it, or the start of a new chain.
    if (agrees) {
      s->suspect_newest = std::max(s->suspect_newest, t);
    } else {
      stats_.discarded += static_cast<int64_t>(s->held.size());
      s->held.clear();
      s->suspects = 0;
      s->suspect_newest = t;
    }
    if (++s->suspects < std::max(1, params_.confirm)) {
      s->held.emplace_back(std::forward<Again>(again));
      ++stats_.held;
      return Verdict::kHeld;
    }
    // Confirmed: the sender's clock is on a new timeline, the reference from now on (a bogus
    // newest of everyone's must not outlive a timeline that is confirmed).
    went_back_ = s->suspect_newest < s->newest;
    newest_ = s->suspect_newest;
    s->newest = s->suspect_newest;
    s->suspects = 0;
    releasing_.swap(s->held);
    s->held.clear();
    ++stats_.reanchors;
    if (went_back_) ++stats_.reanchors_back;
    ++stats_.accepted;
    return Verdict::kReanchor;
  }
  // check() and what follows in one call, for an estimator's input handler: true when the message
  // is to be used now. A suspect is held (`again` hands it over later); on a re-anchoring,
  // `restart_sender()` runs first when time went back, then the held messages are handed over.
  template <class Again, class Restart>
  bool admit(const std::string& sender, utime_t t, Again&& again, Restart&& restart_sender) {
    switch (check(sender, t, std::forward<Again>(again))) {
      case Verdict::kAccept: return true;
      case Verdict::kHeld: return false;
      case Verdict::kReanchor: break;
    }
    if (went_back_) restart_sender();
    release();
    return true;
  }
  // A stamp another guard has checked already (a hosted estimator's, which may also hand over
  // old work late: a blink it closes after a silence). Taken as the sender's newest when newer;
  // false when it is further back than max_behind_s (stale: the caller drops it) unless
  // `went_back` (that guard re-anchored back in time: then it is the sender's newest, and the
  // caller starts what it keeps of the sender afresh).
  bool note(const std::string& sender, utime_t t, bool went_back = false) {
    Sender* s = sender_for(sender);
    if (!went_back && s->newest != 0 && t < s->newest - s_to_utime(params_.max_behind_s))
      return false;
    // Suspects held meanwhile that agree with this stamp are confirmed by it (the caller calls
    // release()); others are refuted.
    const bool confirms = s->suspects > 0 && t <= s->suspect_newest + ahead_of(*s) &&
                          t >= s->suspect_newest - s_to_utime(params_.max_behind_s);
    s->newest = went_back ? t : std::max(s->newest, t);
    newest_ = went_back ? t : std::max(newest_, t);
    if (confirms) {
      s->newest = std::max(s->newest, s->suspect_newest);
      newest_ = std::max(newest_, s->newest);
      for (auto& fn : s->held) releasing_.push_back(std::move(fn));
      ++stats_.reanchors;
    } else {
      stats_.discarded += static_cast<int64_t>(s->held.size());
    }
    s->held.clear();
    s->suspects = 0;
    ++stats_.accepted;
    return true;
  }
  // After kReanchor: whether time went back for that sender.
  bool went_back() const { return went_back_; }
  // After kReanchor: hands the held suspects to the estimator again, in their order.
  void release() {
    std::vector<std::function<void()>> r;
    r.swap(releasing_);
    stats_.released += static_cast<int64_t>(r.size());
    for (auto& fn : r) fn();
  }
  // The newest time accepted from anyone (0 before the first).
  utime_t newest() const { return newest_; }
  const TimeGuardStats& stats() const { return stats_; }
  // Messages dropped for their time stamp so far (refuted suspects).
  int64_t dropped() const { return stats_.discarded; }
  // Suspects held now, not yet released or discarded.
  int64_t pending() const {
    int64_t n = 0;
    for (const auto& [name, s] : senders_) n += static_cast<int64_t>(s.held.size());
    return n;
  }

 private:
  struct Sender {
    utime_t newest = 0;  // 0: nothing accepted yet
    utime_t suspect_newest = 0;
    utime_t last_seen = 0;  // the stamp of the sender's last message, whatever became of it
    utime_t interval = 0;   // its usual interval (0: not known yet)
    int suspects = 0;
    std::vector<std::function<void()>> held;
  };

  // The sender's usual interval between messages, from the stamps as they come (accepted or
  // not; gaps beyond kMaxIntervalS, and steps back, left out), smoothed: a slow sender's next
  // message is one interval ahead of its newest.
  static constexpr double kMaxIntervalS = 10.0;
  void learn_interval(Sender& s, utime_t t) {
    const utime_t d = t - s.last_seen;
    if (s.last_seen != 0 && d > 0 && d <= s_to_utime(kMaxIntervalS))
      s.interval = s.interval == 0 ? d : s.interval + (d - s.interval) / 8;
    s.last_seen = t;
  }
  utime_t ahead_of(const Sender& s) const { return s_to_utime(params_.max_ahead_s) + 2 * s.interval; }

  bool in_window(const Sender* s, utime_t t) const {
    const utime_t ahead = ahead_of(*s);
    const utime_t behind = s_to_utime(params_.max_behind_s);
    if (newest_ == 0) return true;  // the first message of all sets the reference
    if (s->newest != 0 && t >= s->newest - behind && t <= s->newest + ahead) return true;
    // A sender back from a silence, or heard for the first time: within reach of everyone's.
    const utime_t own = s->newest != 0 ? s->newest : newest_;
    return t >= own - behind && t <= newest_ + ahead;
  }

  Sender* sender_for(const std::string& id) {
    auto it = senders_.find(id);
    if (it != senders_.end()) return &it->second;
    if (senders_.size() >= params_.max_senders) {
      // Forget senders far behind everyone (gone) and holding nothing.
      const utime_t stale = newest_ - s_to_utime(60.0);
      for (auto o = senders_.begin(); o != senders_.end();)
        o = o->second.newest < stale && o->second.held.empty() ? senders_.erase(o) : std::next(o);
      if (senders_.size() >= params_.max_senders) return &overflow_;
    }
    return &senders_.try_emplace(id).first->second;
  }

  TimeGuardParams params_;
  std::map<std::string, Sender> senders_;
  Sender overflow_;  // every sender beyond max_senders shares one
  std::vector<std::function<void()>> releasing_;
  utime_t newest_ = 0;
  bool went_back_ = false;
  TimeGuardStats stats_;
};

}  // namespace ips
