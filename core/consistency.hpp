#pragma once
// Does an estimator's input agree with the noise it assumes? Per input kind and source (an
// anchor, a sensor), a window of normalised innovations squared (NIS) against their chi-square
// expectation, and the share of gated measurements. A wrong noise setting or a broken sensor
// then shows by name ("BARO B1: innovations 11x their assumed variance; pressure_sigma_pa 0.5
// looks too small for this sensor") instead of giving confident nonsense.
//
// The test is robust: the window's MEDIAN NIS over the chi-square median for its degrees of
// freedom, so that a few outliers (NLOS ranges, a slammed door) do not make a channel look noisy,
// while a setting 10x too small (NIS 100x) shows within a dozen measurements. Gated measurements
// are passed too: a sigma far too small gates nearly everything, and that must show.
//
// Scalar channels can learn their noise online (on by default, off by a site setting): the
// variance to use is the window's median r^2 / 0.455 (the chi-square(1) median) minus the median
// prediction variance H P H', clamped to [learn_min, learn_max] x the configured variance (the
// configured value is a floor: see ConsistencyOptions). A
// learned value within its bounds compensates, so the channel is reported but the process is
// not degraded; at a bound, or with learning off, it is.
//
// Learning per link. A measurement between a tag and an anchor names its tag (`link`): the
// variance it is given is then learned from that tag's measurements of that anchor only, while
// the verdicts (HEALTH, the replay's summary) stay per anchor. A tag in an NLOS corner of one
// anchor then widens its own ranges of that anchor, not every tag's, and a tag's estimates depend
// on its own measurements only: a shard (--shard K/N) or a replay lane estimates it as one
// instance does. A link keeps only what learning needs (its window's r^2 and H P H' as floats);
// with one tag its learned variance is its anchor's.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <map>
#include <string>
#include <string_view>
#include <tuple>
#include <utility>
#include <vector>

namespace ips {

// The median of a chi-square distribution with `dof` degrees of freedom (exact table to 6, then
// the Wilson-Hilferty approximation).
inline double chi2_median(int dof) {
  static constexpr double kTable[] = {0.0, 0.45494, 1.38629, 2.36597, 3.35669, 4.35146, 5.34812};
  if (dof <= 0) return kTable[1];
  if (dof <= 6) return kTable[dof];
  const double k = dof;
  const double c = 1.0 - 2.0 / (9.0 * k);
  return k * c * c * c;
}

// A setting as the user writes it, for the monitor's words: "range_sigma_m 0.1".
inline std::string setting_text(std::string_view key, double value) {
  char buf[40];
  std::snprintf(buf, sizeof buf, " %g", value);
  return std::string(key) + buf;
}

struct ConsistencyOptions {
  double window_s = 20.0;    // innovations older than this (measurement time) leave the window
  size_t max_samples = 300;  // per channel, the newest kept
  size_t min_samples = 10;   // fewer in the window: no verdict, nothing learned
  double too_noisy = 5.0;    // median NIS / chi-square median above this: noisier than assumed
  double too_quiet = 0.1;    // below this: the assumed noise is far larger than the data's
  double gated_warn = 0.3;   // a share of gated measurements above this is said
  // A process is degraded by a channel only when this many of its checks in a row (one every 10
  // samples) found it noisier than assumed: a verdict from 10 samples scatters, and a filter's
  // first second can disagree with a sensor that is fine (ips-fuse's first 15 angles of B1 in
  // the demo's lab at 7.6x, the rest of the run 1.6x; under load its HEALTH caught that moment).
  int noisy_checks = 2;
  bool learn = true;         // scalar channels learn their noise (site: <estimator>.learn_noise)
  // Learned variance bounds, times the configured variance (sigma 1x to 20x the configured one).
  // The configured value is a floor: innovations understate time-correlated noise (a device
  // that smooths its ranges, a bias that the track absorbs), so a quiet channel is never taken
  // as a reason to trust it more.
  double learn_min = 1.0;
  double learn_max = 400.0;
  double learn_deadband = 2.0;  // a learned variance below this x the configured one is not used
};

class ConsistencyMonitor {
 public:
  enum class State { kTooFew, kOk, kNoisy, kQuiet };
  struct Verdict {
    std::string kind, source, setting;
    size_t n = 0;              // samples in the window
    double ratio = NAN;        // median NIS / chi-square median (1 when consistent)
    double gated_share = 0.0;  // of the window
    State state = State::kTooFew;
    bool scalar = false;
    double learned_sigma = NAN;  // scalar channels with learning: the sigma in use now, in the
                                 // innovation's units
    double learned_factor = NAN; // ... over the configured sigma
    bool compensated = false;    // learning covers the mismatch (within its bounds)
  };

  explicit ConsistencyMonitor(ConsistencyOptions o = {}) : opts_(o) {}
  const ConsistencyOptions& options() const { return opts_; }
  void set_learning(bool on) { opts_.learn = on; }
  // Channels of `kind` are checked, never learned (their variance is not the estimator's to
  // scale: e.g. a TDoA difference's comes from the clock filters).
  void monitor_only(std::string_view kind) { monitor_only_.emplace_back(kind); }

  // A link's handle (link(): its kind, source and tag), for the variance learned per link (above).
  using LinkId = int32_t;
  static constexpr LinkId kNoLink = -1;
  // The handle of a link, made on first use; valid until the monitor is replaced or cleared (an
  // estimator keeps one per tag and anchor, in the tag's track).
  LinkId link(std::string_view kind, std::string_view source, std::string_view tag) {
    const std::string k = key_of(kind, source) + '\x1f' + std::string(tag);
    const auto it = link_ids_.find(k);
    if (it != link_ids_.end()) return it->second;
    links_.emplace_back();
    return link_ids_[k] = static_cast<LinkId>(links_.size() - 1);
  }

  // link() kept in `cache[index]` (kNoLink until first asked; the cache grows to `size`): an
  // estimator's track keeps its tag's links to the site's anchors so.
  LinkId cached_link(std::vector<LinkId>& cache, size_t index, size_t size, std::string_view kind,
                     std::string_view source, std::string_view tag) {
    if (cache.size() <= index) cache.resize(std::max(size, index + 1), kNoLink);
    if (cache[index] == kNoLink) cache[index] = link(kind, source, tag);
    return cache[index];
  }

  // A scalar measurement: innovation r (measured - predicted), the prediction's variance hph
  // (H P H') and the CONFIGURED measurement variance r_cfg. `setting` names what the user set,
  // as written: "pressure_sigma_pa 0.5".
  // `link`: the link the measurement is of, when the variance is learned per link.
  void add_scalar(std::string_view kind, std::string_view source, double t, double r, double hph,
                  double r_cfg, bool gated, std::string_view setting = {}, LinkId link = kNoLink) {
    if (!std::isfinite(r) || !std::isfinite(hph) || !(r_cfg > 0.0) || !std::isfinite(t)) return;
    Channel& c = channel(kind, source, setting, 1, true);
    push(c, t, Sample{t, r * r / (std::max(hph, 0.0) + r_cfg), r * r, std::max(hph, 0.0), gated});
    c.r_cfg = r_cfg;
    if (++c.since_learn >= 5 || c.window.size() <= opts_.min_samples) relearn(c);
    if (link != kNoLink && c.learns)
      push_link(links_.at(static_cast<size_t>(link)), t, r * r, hph, r_cfg);
  }
  // A vector measurement's normalised innovation squared (against the configured noise).
  void add_nis(std::string_view kind, std::string_view source, double t, double nis, int dof,
               bool gated, std::string_view setting = {}) {
    if (!std::isfinite(nis) || nis < 0.0 || dof <= 0 || !std::isfinite(t)) return;
    Channel& c = channel(kind, source, setting, dof, false);
    push(c, t, Sample{t, nis, NAN, NAN, gated});
  }

  // The variance to use now for a scalar channel: r_cfg until the window holds min_samples (or
  // with learning off), then the learned one within its bounds.
  // With `link`, the link's own (its tag's measurements of the source).
  double variance(std::string_view kind, std::string_view source, double r_cfg,
                  LinkId link = kNoLink) const {
    if (!opts_.learn || !(r_cfg > 0.0)) return r_cfg;
    if (link != kNoLink) {
      if (link < 0 || static_cast<size_t>(link) >= links_.size()) return r_cfg;
      const double scale = links_[static_cast<size_t>(link)].learned_scale;
      return std::isfinite(scale) ? r_cfg * scale : r_cfg;
    }
    const Channel* c = find(kind, source);
    if (c == nullptr || !c->learns || !std::isfinite(c->learned_scale)) return r_cfg;
    return r_cfg * c->learned_scale;
  }

  std::vector<Verdict> verdicts() const {
    std::vector<Verdict> out;
    out.reserve(channels_.size());
    for (const auto& [key, c] : channels_) out.push_back(verdict(c));
    return out;
  }

  // "BARO B1: innovations 11x their assumed variance; pressure_sigma_pa 0.5 looks too small for
  // this sensor (learned sigma 1.7)", one clause per channel out of line, joined by "; ";
  // "" when all agree.
  std::string problems() const {
    std::string s;
    for (const Verdict& v : verdicts()) {
      std::string p = problem_text(v);
      if (p.empty()) continue;
      if (!s.empty()) s += "; ";
      s += p;
    }
    return s;
  }
  // Some channel disagrees with its noise and learning does not cover it: the process is not
  // to be trusted (HEALTH degraded).
  bool degraded() const {
    for (const auto& [key, c] : channels_) {
      if (c.noisy_run < opts_.noisy_checks) continue;
      const Verdict v = verdict(c);
      if (v.state == State::kNoisy && !v.compensated) return true;
    }
    return false;
  }
  // "RANGE A1 1.0x, RANGE A2 3.1x 10% gated, BARO B1 96x (learned sigma 4.9)": every channel with
  // a verdict; "" when none has one yet.
  std::string summary() const {
    std::string s;
    for (const Verdict& v : verdicts()) {
      if (v.state == State::kTooFew) continue;
      if (!s.empty()) s += ", ";
      s += v.kind + " " + v.source + " " + fmt(v.ratio, v.ratio < 10 ? 1 : 0) + "x";
      if (v.gated_share >= 0.005) s += " " + fmt(100.0 * v.gated_share, 0) + "% gated";
      if (std::isfinite(v.learned_sigma) && v.state == State::kNoisy)
        s += " (learned sigma " + learned_text(v) + ")";
    }
    return s;
  }
  // The whole run, for a replay's summary: "RANGE A1: 2034 in, 3% gated, NIS 1.1x (worst 4.2x,
  // noisier than assumed 5% of the time)"; channels joined by "; ".
  std::string run_summary() const {
    std::string s;
    for (const auto& [key, c] : channels_) {
      if (!s.empty()) s += "; ";
      s += c.kind + " " + c.source + ": " + std::to_string(c.total) + " in";
      if (c.total_gated > 0)
        s += ", " + fmt(100.0 * static_cast<double>(c.total_gated) / static_cast<double>(c.total), 0) +
             "% gated";
      const Verdict v = verdict(c);
      if (v.state != State::kTooFew) s += ", NIS " + fmt(v.ratio, v.ratio < 10 ? 1 : 0) + "x";
      if (c.checks > 0) {
        s += " (worst " + fmt(c.worst, c.worst < 10 ? 1 : 0) + "x";
        if (c.checks_out > 0)
          s += ", noisier than assumed " +
               fmt(100.0 * static_cast<double>(c.checks_out) / static_cast<double>(c.checks), 0) +
               "% of the time";
        s += ")";
      }
      if (std::isfinite(v.learned_sigma) && v.state == State::kNoisy)
        s += ", learned sigma " + learned_text(v);
    }
    return s;
  }
  size_t channels() const { return channels_.size(); }
  size_t links() const { return links_.size(); }
  void clear() {
    channels_.clear();
    links_.clear();
    link_ids_.clear();
  }

 private:
  struct Sample {
    double t, nis, r2, hph;
    bool gated;
  };
  // A window's values kept in order, so that its median is read, not searched for (a replay
  // adds a sample per range: a selection over 300 values each time was a quarter of its time).
  template <class T>
  class SortedValues {
   public:
    void add(T x) { v_.insert(upper_bound(x), x); }
    void remove(T x) {
      const auto it = lower_bound(x);
      if (it != v_.end() && !(x < *it)) v_.erase(it);
    }
    // remove(out) then add(in) in one pass: only the values between the two places move (a
    // full window's step, a third of the window on average instead of all of it).
    void replace(T out, T in) {
      const auto it = lower_bound(out);
      if (it == v_.end() || out < *it) return add(in);
      const auto to = upper_bound(in);
      if (to > it + 1) {
        std::move(it + 1, to, it);
        *(to - 1) = in;
      } else if (to <= it) {
        std::move_backward(to, it, it + 1);
        *to = in;
      } else {
        *it = in;
      }
    }
    void clear() { v_.clear(); }
    // The middle value; of an even count, the mean of the two middle ones. NaN when empty.
    double median() const {
      if (v_.empty()) return NAN;
      const size_t mid = v_.size() / 2;
      return v_.size() % 2 == 0 ? 0.5 * (static_cast<double>(v_[mid]) + v_[mid - 1])
                                : static_cast<double>(v_[mid]);
    }

    // std::lower_bound's and std::upper_bound's places, found without branches on the values
    // (a conditional move per halving): which half a new NIS falls in is a coin toss, and the
    // mispredicted branches of six searches per sample were most of a replay's monitoring.
    typename std::vector<T>::iterator lower_bound(T x) {
      return v_.begin() + partition_point([x](T v) { return v < x; });
    }
    typename std::vector<T>::iterator upper_bound(T x) {
      return v_.begin() + partition_point([x](T v) { return !(x < v); });
    }

   private:
    // The first index where `before` is false (it is true for a prefix of the values).
    template <class Before>
    std::ptrdiff_t partition_point(Before before) const {
      size_t n = v_.size();
      if (n == 0) return 0;
      const T* base = v_.data();
      while (n > 1) {
        const size_t half = n / 2;
        base = before(base[half]) ? base + half : base;
        n -= half;
      }
      return (base - v_.data()) + (before(*base) ? 1 : 0);
    }
    std::vector<T> v_;
  };
  using Sorted = SortedValues<double>;
  struct Channel {
    std::string kind, source, setting;
    int dof = 1;
    bool scalar = false;
    bool learns = false;  // a scalar channel, learning on, not monitor_only
    double r_cfg = NAN;
    double learned_scale = NAN;  // learned variance / r_cfg, NaN until learned
    bool at_bound = false;
    int since_learn = 0;
    std::deque<Sample> window;
    Sorted nis_sorted, r2_sorted, hph_sorted;  // the window's values, in order
    int64_t gated_in_window = 0;
    // Over the whole run: samples, gated ones, and the verdicts taken every 10 samples.
    int64_t total = 0, total_gated = 0;
    int64_t checks = 0, checks_out = 0;  // verdicts, and those noisy or too quiet
    double worst = NAN;                  // the largest windowed ratio seen
    int since_check = 0;
    int noisy_run = 0;  // the checks in a row (the last ones) that found it noisy
  };
  // A link's learning: its window's r^2 and H P H' (floats: 100 tags x 8 anchors at 10 Hz keep
  // 160 000 of them), in arrival order and in order.
  struct LinkSample {
    double t;
    float r2, hph;
  };
  struct Link {
    std::deque<LinkSample> window;
    SortedValues<float> r2_sorted, hph_sorted;
    double learned_scale = NAN;
    int since_learn = 0;
  };

  // As push() and relearn() for a channel, for a link's learning only.
  void push_link(Link& l, double t, double r2, double hph, double r_cfg) {
    if (!l.window.empty() && t < l.window.back().t - opts_.window_s) {
      l.window.clear();
      l.r2_sorted.clear();
      l.hph_sorted.clear();
    }
    while (!l.window.empty() &&
           (l.window.size() >= opts_.max_samples || l.window.front().t < t - opts_.window_s)) {
      l.r2_sorted.remove(l.window.front().r2);
      l.hph_sorted.remove(l.window.front().hph);
      l.window.pop_front();
    }
    const LinkSample s{t, static_cast<float>(r2), static_cast<float>(std::max(hph, 0.0))};
    l.window.push_back(s);
    l.r2_sorted.add(s.r2);
    l.hph_sorted.add(s.hph);
    if (++l.since_learn < 5 && l.window.size() > opts_.min_samples) return;
    l.since_learn = 0;
    if (l.window.size() < opts_.min_samples) return;
    l.learned_scale =
        learned_scale_of(measurement_scale(l.r2_sorted.median(), l.hph_sorted.median(), r_cfg));
  }
  // The scale a window's estimate gives: 1 below the deadband, else within the bounds.
  double learned_scale_of(double scale) const {
    return !std::isfinite(scale) || scale < opts_.learn_deadband
               ? 1.0
               : std::clamp(scale, opts_.learn_min, opts_.learn_max);
  }
  static std::string key_of(std::string_view kind, std::string_view source) {
    std::string k(kind);
    k += '\x1f';
    k += source;
    return k;
  }
  const Channel* find(std::string_view kind, std::string_view source) const {
    auto it = channels_.find(key_of(kind, source));
    return it == channels_.end() ? nullptr : &it->second;
  }
  Channel& channel(std::string_view kind, std::string_view source, std::string_view setting,
                   int dof, bool scalar) {
    Channel& c = channels_[key_of(kind, source)];
    if (c.kind.empty()) {
      c.kind = kind;
      c.source = source;
    }
    if (!setting.empty() && c.setting != setting) c.setting = setting;
    c.dof = dof;
    c.scalar = scalar;
    c.learns = scalar && opts_.learn &&
               std::find(monitor_only_.begin(), monitor_only_.end(), kind) == monitor_only_.end();
    return c;
  }
  void push(Channel& c, double t, const Sample& s) {
    // A clock that went back (a restarted sender, a replay) starts the window afresh.
    if (!c.window.empty() && t < c.window.back().t - opts_.window_s) {
      c.window.clear();
      c.nis_sorted.clear();
      c.r2_sorted.clear();
      c.hph_sorted.clear();
      c.gated_in_window = 0;
      c.noisy_run = 0;
    }
    // The samples that leave (the window full, or older than window_s) leave first; the first
    // of them swaps places with the new one in the ordered values (the same values result).
    bool entered = false;
    while (!c.window.empty() && (c.window.size() >= opts_.max_samples ||
                                 c.window.front().t < t - opts_.window_s)) {
      if (entered) {
        enter(c, c.window.front(), false);
      } else {
        swap_in(c, c.window.front(), s);
        entered = true;
      }
      c.window.pop_front();
    }
    if (!entered) enter(c, s, true);
    c.window.push_back(s);
    ++c.total;
    c.total_gated += s.gated ? 1 : 0;
    if (++c.since_check >= 10 && c.window.size() >= opts_.min_samples) {
      c.since_check = 0;
      const auto [ratio, state] = ratio_state(c);
      ++c.checks;
      if (state == State::kNoisy) ++c.checks_out;
      c.noisy_run = state == State::kNoisy ? c.noisy_run + 1 : 0;
      if (!(c.worst >= ratio)) c.worst = ratio;
    }
  }
  // `out` leaves the window's ordered values and `in` enters them.
  static void swap_in(Channel& c, const Sample& out, const Sample& in) {
    c.nis_sorted.replace(out.nis, in.nis);
    swap_value(c.r2_sorted, out.r2, in.r2);
    swap_value(c.hph_sorted, out.hph, in.hph);
    c.gated_in_window += (in.gated ? 1 : 0) - (out.gated ? 1 : 0);
  }
  static void swap_value(Sorted& sorted, double out, double in) {
    if (!std::isnan(out) && !std::isnan(in)) sorted.replace(out, in);
    else if (!std::isnan(out)) sorted.remove(out);
    else if (!std::isnan(in)) sorted.add(in);
  }
  // A sample into (in) or out of the window's ordered values (r^2 and H P H' are NaN for a
  // vector measurement's sample, and not kept).
  static void enter(Channel& c, const Sample& s, bool in) {
    if (in) {
      c.nis_sorted.add(s.nis);
      if (!std::isnan(s.r2)) c.r2_sorted.add(s.r2);
      if (!std::isnan(s.hph)) c.hph_sorted.add(s.hph);
    } else {
      c.nis_sorted.remove(s.nis);
      if (!std::isnan(s.r2)) c.r2_sorted.remove(s.r2);
      if (!std::isnan(s.hph)) c.hph_sorted.remove(s.hph);
    }
    c.gated_in_window += (s.gated ? 1 : 0) * (in ? 1 : -1);
  }
  // The window's measurement variance (median r^2 over the chi-square(1) median, less the median
  // H P H') over the configured one.
  static double noise_scale(const Channel& c) {
    return measurement_scale(c.r2_sorted.median(), c.hph_sorted.median(), c.r_cfg);
  }
  static double measurement_scale(double r2_median, double hph_median, double r_cfg) {
    return (r2_median / chi2_median(1) - hph_median) / r_cfg;
  }

  void relearn(Channel& c) {
    c.since_learn = 0;
    if (c.window.size() < opts_.min_samples) return;
    const double scale = noise_scale(c);
    c.at_bound = !(scale < opts_.learn_max);
    // Below learn_deadband the configured value stands: an estimate from a few dozen samples
    // scatters by tens of percent, and a consistent channel must not jitter.
    c.learned_scale = learned_scale_of(scale);
  }
  // The window's ratio (median NIS over the chi-square median) and the state it gives; NaN and
  // kTooFew for an empty window.
  std::pair<double, State> ratio_state(const Channel& c) const {
    const size_t n = c.window.size();
    if (n == 0) return {NAN, State::kTooFew};
    double ratio = c.nis_sorted.median() / chi2_median(c.dof);
    // A scalar channel's own noise against the configured one, whatever the filter's confidence:
    // once a learned variance widens the filter, H P H' grows and the NIS alone understates
    // how far off the setting is.
    if (c.scalar && n >= opts_.min_samples) ratio = std::max(ratio, noise_scale(c));
    if (n < opts_.min_samples) return {ratio, State::kTooFew};
    return {ratio, ratio > opts_.too_noisy  ? State::kNoisy
                   : ratio < opts_.too_quiet ? State::kQuiet
                                             : State::kOk};
  }
  Verdict verdict(const Channel& c) const {
    Verdict v;
    v.kind = c.kind;
    v.source = c.source;
    v.setting = c.setting;
    v.scalar = c.scalar;
    v.n = c.window.size();
    if (v.n == 0) return v;
    v.gated_share = static_cast<double>(c.gated_in_window) / static_cast<double>(v.n);
    std::tie(v.ratio, v.state) = ratio_state(c);
    if (v.state == State::kTooFew) return v;
    if (c.learns && std::isfinite(c.learned_scale)) {
      v.learned_sigma = std::sqrt(c.learned_scale * c.r_cfg);
      v.learned_factor = std::sqrt(c.learned_scale);
      v.compensated = !c.at_bound;
    }
    return v;
  }
  std::string problem_text(const Verdict& v) const {
    if (v.state == State::kTooFew) return "";
    std::string s;
    const std::string name = v.kind + " " + v.source + ": ";
    const std::string what = v.kind == "BARO" ? "sensor" : v.kind == "RANGE" || v.kind == "ANGLE"
                                                               ? "anchor"
                                                               : "input";
    // Too quiet is shown in the summary, not said as a problem: small innovations also come of
    // time-correlated noise and of errors the track absorbs, so they do not prove the setting
    // too large.
    if (v.state == State::kNoisy) {
      s = name + "innovations " + fmt(v.ratio, v.ratio < 10 ? 1 : 0) + "x their assumed variance";
      if (!v.setting.empty()) s += "; " + v.setting + " looks too small for this " + what;
      if (std::isfinite(v.learned_sigma))
        s += std::string(v.compensated ? " (learned sigma " : " (learned sigma at its bound, ") +
             learned_text(v) + ")";
    }
    if (v.gated_share > opts_.gated_warn) {
      if (s.empty()) s = name;
      else s += ", ";
      s += fmt(100.0 * v.gated_share, 0) + "% of its measurements gated";
    }
    return s;
  }
  // The learned sigma in the setting's own units ("mag_heading_sigma_deg 2" learned 8x: "16"),
  // whatever units the innovations come in (radians, metres of a time difference); as a factor
  // ("8.3x the configured") when the setting is not one "key value" pair.
  static std::string learned_text(const Verdict& v) {
    const size_t space = v.setting.rfind(' ');
    if (space != std::string::npos && v.setting.find(' ') == space) {
      const std::string number = v.setting.substr(space + 1);
      char* end = nullptr;
      const double value = std::strtod(number.c_str(), &end);
      if (end != number.c_str() && *end == '\0' && std::isfinite(value) && value > 0)
        return fmt(value * v.learned_factor, -3);
    }
    if (v.setting.empty()) return fmt(v.learned_sigma, -3);
    return fmt(v.learned_factor, v.learned_factor < 10 ? 1 : 0) + "x the configured";
  }
  // `digits` decimals, or (digits < 0) -digits significant digits.
  static std::string fmt(double v, int digits) {
    char buf[32];
    if (digits >= 0) std::snprintf(buf, sizeof buf, "%.*f", digits, v);
    else std::snprintf(buf, sizeof buf, "%.*g", -digits, v);
    return buf;
  }

  ConsistencyOptions opts_;
  std::vector<std::string> monitor_only_;
  std::map<std::string, Channel> channels_;
  std::deque<Link> links_;                  // learning per link, by LinkId
  std::map<std::string, LinkId> link_ids_;  // (kind, source, tag) -> LinkId
};

// A live process's report of its estimator's consistency in HEALTH, from its 1 Hz timer:
// the summary goes to HEALTH's `consistency` field, and while some channel is out of line and
// not compensated the process is degraded with the problem as a lasting error. `NodeT` is
// ips::Node (anything with set_consistency, report_lasting_error, end_lasting_error).
class ConsistencyHealth {
 public:
  template <class NodeT>
  void report(NodeT& node, const ConsistencyMonitor& m) {
    const std::string problems = m.problems();
    node.set_consistency(problems.empty() ? m.summary() : problems);
    if (m.degraded()) {
      // On entering, and every 10 reports after, so last_error follows the figures.
      if (reports_bad_++ % 10 == 0) node.report_lasting_error("consistency", problems);
    } else if (reports_bad_ > 0) {
      node.end_lasting_error("consistency");
      reports_bad_ = 0;
    }
  }

 private:
  int64_t reports_bad_ = 0;
};

}  // namespace ips
