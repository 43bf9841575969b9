#pragma once
// Two-way ranging from a UWB chip's raw exchange timestamps (DW1000/DW3000 and alike): the
// single-sided (SS-TWR, 4 stamps, needs the clock offset between tag and anchor) and the
// asymmetric double-sided (DS-TWR, 6 stamps) time of flight, counters that wrap (40-bit, or only
// their low 32 bits kept), and the clock offset of a tag-anchor pair measured across consecutive
// exchanges. Pure: numbers in, numbers out; no clock, no I/O.
//
// Clocks: poll_tx, resp_rx, final_tx are read on the tag's (initiator's) counter; poll_rx,
// resp_tx, final_rx on the anchor's (responder's). A clock offset r is the anchor's rate relative
// to the tag's, f_anchor / f_tag - 1 (positive: the anchor's counter runs fast).
#include <cstdint>
#include <deque>
#include <limits>
#include <map>
#include <optional>
#include <string>

namespace ips::twr {

inline constexpr double kSpeedOfLight = 299792458.0;  // m/s
// DW1000/DW3000: 1 tick = 1 / (128 * 499.2 MHz), about 15.65 ps.
inline constexpr double kDw1000TickS = 1.0 / (128.0 * 499.2e6);

// Counter widths a source may have: a DW1000 counter is 40 bits; many logs keep its low 32.
inline bool valid_counter_bits(int bits) { return bits >= 16 && bits <= 62; }

// True when `v` is a reading of a `bits`-wide counter, stored unsigned [0, 2^bits) or signed
// [-2^(bits-1), 2^(bits-1)).
bool fits_counter(int64_t v, int bits);

// later - earlier on one counter, modulo 2^bits, in [0, 2^bits): an elapsed time of less than one
// wrap.
int64_t counter_elapsed(int64_t later, int64_t earlier, int bits);
// a - b modulo 2^bits as a signed number in [-2^(bits-1), 2^(bits-1)): a small difference either
// way.
int64_t counter_diff(int64_t a, int64_t b, int bits);

// One exchange's stamps (ticks). SS-TWR uses the first four.
struct Stamps {
  int64_t poll_tx = 0, poll_rx = 0, resp_tx = 0, resp_rx = 0, final_tx = 0, final_rx = 0;
};

// The intervals of an exchange (ticks, each less than one wrap): Ra = resp_rx - poll_tx (tag),
// Db = resp_tx - poll_rx (anchor); DS-TWR adds Rb = final_rx - resp_tx (anchor), Da = final_tx -
// resp_rx (tag).
struct Intervals {
  int64_t ra = 0, db = 0, rb = 0, da = 0;
};
Intervals intervals(const Stamps& s, int bits);

// SS-TWR time of flight in ticks: (Ra - Db * (1 - r)) / 2, r the clock offset (anchor rate
// relative to the tag's, e.g. 1e-6 for +1 ppm; 0 when unknown: then a 1 ppm offset errs by
// Db * 1e-6 / 2 ticks, ~17 cm at Db = 72e6 ticks, 1.1 ms).
double ss_twr_tof_ticks(const Intervals& iv, double clock_offset);
// Asymmetric DS-TWR time of flight in ticks: (Ra*Rb - Da*Db) / (Ra + Rb + Da + Db), exact in
// integers up to the division; independent of the clock offset to first order. NaN when the
// denominator is not positive.
double ds_twr_tof_ticks(const Intervals& iv);
// The clock offset a DS-TWR exchange shows: (Rb + Db) / (Ra + Da) - 1 (anchor relative to tag).
double ds_twr_clock_offset(const Intervals& iv);

inline double ticks_to_m(double ticks, double tick_s) { return ticks * tick_s * kSpeedOfLight; }

// --- clock offset across exchanges -------------------------------------------------------------

// The offset of one tag-anchor pair from consecutive SS-TWR exchanges: between two polls, the
// anchor's counter advanced (poll_rx - poll_rx') while the tag's advanced (poll_tx - poll_tx');
// their difference d (small, read modulo the wrap) over the interval's length T is the offset,
// r = d / T. T itself needs no precision beyond a per mil (an error of x in T is x*r in r), but
// a counter of 32 bits wraps every 67 ms, so its reading gives T only modulo the wrap: the host's
// time between the two exchanges (utime) picks the wrap count. When the host time is not within
// `wrap_tolerance` of a whole number of wraps past the counter's reading (the host stamps rows
// late or early, or the counter does not run between exchanges) the host time is T (counted in
// host_interval). The offset used is the median of the last `median_of` measurements, which
// keeps one exchange with a late host stamp from moving it.
struct ClockOffsetOptions {
  double max_interval_s = 5.0;   // a longer gap starts the pair afresh
  double max_abs_ppm = 200.0;    // beyond: not a clock offset (counted, not used)
  double wrap_tolerance = 0.05;  // of one wrap, for taking the counter's interval
  int median_of = 5;
};

struct ClockOffsetTally {
  int64_t exchanges = 0;         // update() calls
  int64_t measured = 0;          // intervals that gave an offset
  int64_t counter_interval = 0;  // ... whose length came from the counter (wrap count resolved)
  int64_t host_interval = 0;     // ... whose length came from the host's time
  int64_t restarts = 0;          // first exchange of a pair, a gap, or time going backwards
  int64_t implausible = 0;       // an interval whose offset was beyond max_abs_ppm
};

class ClockOffsetTracker {
 public:
  explicit ClockOffsetTracker(ClockOffsetOptions options = {}) : options_(options) {}

  // One exchange of the pair `key` (any string naming tag and anchor): its host time (us) and its
  // poll stamps on the tag's and the anchor's counter. Returns the offset to use for this
  // exchange (ratio, e.g. -1e-6), nullopt while the pair has no measurement yet.
  std::optional<double> update(const std::string& key, int64_t utime, int64_t poll_tx,
                               int64_t poll_rx, int bits, double tick_s);
  const ClockOffsetTally& tally() const { return tally_; }

 private:
  struct Pair {
    int64_t utime = 0, poll_tx = 0, poll_rx = 0;
    std::deque<double> recent;
  };
  ClockOffsetOptions options_;
  std::map<std::string, Pair> pairs_;
  ClockOffsetTally tally_;
};

}  // namespace ips::twr
