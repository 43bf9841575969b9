// core/twr_timestamps: SS-TWR and DS-TWR on exchanges synthesised from a model with known time of
// flight, clock drift (+-20 ppm) and counters that wrap (40 bits, and only their low 32 kept); the
// clock offset tracker across consecutive exchanges with the host's jittery time; and rows of a
// real DW1000 recording (uwb-cucudasluv, Apache-2.0: tests/data/real/uwb-cucudasluv/SOURCE.md).
#include "core/twr_timestamps.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <random>

namespace ips::twr {
namespace {

constexpr double kTick = kDw1000TickS;

// A free-running counter: rate 1 + drift (relative to true time), a start offset, read modulo
// 2^bits and stored as the chip would (unsigned).
struct Clock {
  double drift = 0;     // e.g. 20e-6
  double start_s = 0;   // the counter's reading at true time 0, s
  int bits = 40;
  int64_t at(double t) const {
    const double ticks = std::floor((start_s + t * (1.0 + drift)) / kTick);
    const double wrap = std::ldexp(1.0, bits);
    return static_cast<int64_t>(ticks - std::floor(ticks / wrap) * wrap);
  }
  // True time after `from` when the counter has advanced by `ticks`.
  double after(double from, double ticks) const { return from + ticks * kTick / (1.0 + drift); }
};

struct Exchange {
  Stamps s;
  double t_poll = 0;
};

// One exchange at true time t0: poll from the tag, the anchor replies `db_s` later on its own
// clock, the tag sends the final `da_s` after the response on its clock.
Exchange exchange(const Clock& tag, const Clock& anchor, double t0, double tof_s, double db_s,
                  double da_s) {
  Exchange e;
  e.t_poll = t0;
  e.s.poll_tx = tag.at(t0);
  const double t_poll_rx = t0 + tof_s;
  e.s.poll_rx = anchor.at(t_poll_rx);
  const double t_resp_tx = anchor.after(t_poll_rx, db_s / kTick);
  e.s.resp_tx = anchor.at(t_resp_tx);
  const double t_resp_rx = t_resp_tx + tof_s;
  e.s.resp_rx = tag.at(t_resp_rx);
  const double t_final_tx = tag.after(t_resp_rx, da_s / kTick);
  e.s.final_tx = tag.at(t_final_tx);
  e.s.final_rx = anchor.at(t_final_tx + tof_s);
  return e;
}

double offset_of(const Clock& tag, const Clock& anchor) {
  return (1.0 + anchor.drift) / (1.0 + tag.drift) - 1.0;
}

TEST(TwrTimestamps, CounterArithmeticWraps) {
  EXPECT_EQ(counter_elapsed(5, (int64_t{1} << 32) - 3, 32), 8);
  EXPECT_EQ(counter_elapsed(5, -3, 32), 8);  // the same low word, stored signed
  EXPECT_EQ(counter_diff(-3, 5, 32), -8);
  EXPECT_EQ(counter_diff(3, (int64_t{1} << 40) - 5, 40), 8);
  EXPECT_TRUE(fits_counter(-(int64_t{1} << 31), 32));
  EXPECT_TRUE(fits_counter((int64_t{1} << 32) - 1, 32));
  EXPECT_FALSE(fits_counter(int64_t{1} << 32, 32));
  EXPECT_FALSE(fits_counter(-(int64_t{1} << 31) - 1, 32));
  EXPECT_TRUE(fits_counter((int64_t{1} << 40) - 1, 40));
}

TEST(TwrTimestamps, SsTwrRecoversTofWithTheOffsetAndErrsWithout) {
  const double tof = 30.0 / kSpeedOfLight;  // 30 m
  for (const int bits : {40, 32}) {
    for (const double drift_a : {-20e-6, 0.0, 20e-6}) {
      Clock tag{+15e-6, 12.345, bits};
      Clock anchor{drift_a, 3.21, bits};
      // Start just before the anchor's low word wraps, so the reply straddles it.
      const double wrap_s = std::ldexp(1.0, bits) * kTick;
      const double t0 = (wrap_s - std::fmod(anchor.start_s, wrap_s)) / (1.0 + drift_a) - 0.5e-3;
      const Exchange e = exchange(tag, anchor, t0, tof, 1.13e-3, 0.5e-3);
      const Intervals iv = intervals(e.s, bits);
      const double r = offset_of(tag, anchor);
      const double m = ticks_to_m(ss_twr_tof_ticks(iv, r), kTick);
      EXPECT_NEAR(m, 30.0, 0.01) << bits << " bits, anchor drift " << drift_a;
      // Uncorrected, the error is -Db * r / 2 ticks (|r| >= 5 ppm here: 0.85 m or more).
      const double unc = ticks_to_m(ss_twr_tof_ticks(iv, 0.0), kTick);
      EXPECT_NEAR(unc - 30.0, -ticks_to_m(static_cast<double>(iv.db) * r / 2.0, kTick), 0.01);
      EXPECT_GT(std::fabs(unc - 30.0), 0.5);
    }
  }
}

TEST(TwrTimestamps, DsTwrRecoversTofUnderDriftAndWraps) {
  for (const int bits : {40, 32}) {
    for (const double d_tag : {-20e-6, 20e-6}) {
      for (const double d_anchor : {-20e-6, 0.0, 20e-6}) {
        for (const double metres : {0.5, 12.0, 80.0}) {
          Clock tag{d_tag, 100.0, bits};
          Clock anchor{d_anchor, 7.0, bits};
          // Asymmetric replies (0.3 ms and 2.1 ms), at a time where the tag's low word wraps
          // between response and final.
          const double wrap_s = std::ldexp(1.0, bits) * kTick;
          const double t0 = (wrap_s - std::fmod(tag.start_s, wrap_s)) / (1.0 + d_tag) - 1.0e-3;
          const Exchange e = exchange(tag, anchor, t0, metres / kSpeedOfLight, 0.3e-3, 2.1e-3);
          const Intervals iv = intervals(e.s, bits);
          EXPECT_NEAR(ticks_to_m(ds_twr_tof_ticks(iv), kTick), metres, 0.01)
              << bits << " bits, drift " << d_tag << "/" << d_anchor;
          EXPECT_NEAR(ds_twr_clock_offset(iv) * 1e6, offset_of(tag, anchor) * 1e6, 0.01);
          // The same exchange read as SS-TWR without the offset is metres off.
          if (d_tag != d_anchor) {
            EXPECT_GT(std::fabs(ticks_to_m(ss_twr_tof_ticks(iv, 0.0), kTick) - metres), 0.5);
          }
        }
      }
    }
  }
}

TEST(TwrTimestamps, DsTwrRejectsADegenerateExchange) {
  EXPECT_TRUE(std::isnan(ds_twr_tof_ticks(Intervals{})));
}

// A tag polling every ~144 ms (2.1 wraps of a 32-bit counter); host stamps jitter by 0.5 ms and
// now and then arrive 20 ms late.
TEST(ClockOffsetTracker, MeasuresTheOffsetAcrossWrapsFromHostTime) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> jitter(-0.5e-3, 0.5e-3);
  for (const int bits : {32, 40}) {
    Clock tag{-3e-6, 0.25, bits};
    Clock anchor{+9e-6, 1.75, bits};
    const double r_true = offset_of(tag, anchor);
    ClockOffsetTracker tracker;
    const double tof = 30.0 / kSpeedOfLight;
    int checked = 0;
    for (int i = 0; i < 60; ++i) {
      const double t = 1000.0 + i * 0.1443 + (i % 7 == 3 ? 0.0 : 1e-4 * (i % 3));
      const Exchange e = exchange(tag, anchor, t, tof, 1.13e-3, 0.5e-3);
      const double host = t + jitter(rng) + (i % 11 == 5 ? 0.020 : 0.0);
      const auto r = tracker.update("T1/A1", static_cast<int64_t>(std::llround(host * 1e6)),
                                    e.s.poll_tx, e.s.poll_rx, bits, kTick);
      if (i == 0) {
        EXPECT_FALSE(r.has_value());
        continue;
      }
      ASSERT_TRUE(r.has_value());
      if (i < 5) continue;  // the median needs a few
      ++checked;
      EXPECT_NEAR(*r * 1e6, r_true * 1e6, 0.05) << bits << " bits, exchange " << i;
      const double m = ticks_to_m(ss_twr_tof_ticks(intervals(e.s, bits), *r), kTick);
      EXPECT_NEAR(m, 30.0, 0.02);
    }
    EXPECT_EQ(checked, 55);
    EXPECT_EQ(tracker.tally().exchanges, 60);
    EXPECT_EQ(tracker.tally().restarts, 1);
    EXPECT_EQ(tracker.tally().measured, 59);
    // 40 bits: the counter's interval is always unambiguous; 32 bits: most host stamps are within
    // 0.05 of a wrap (3.4 ms) of it.
    EXPECT_GT(tracker.tally().counter_interval, 40);
  }
}

TEST(ClockOffsetTracker, AGapOrTimeGoingBackRestartsThePair) {
  ClockOffsetTracker tracker;
  Clock tag{0, 0, 40}, anchor{5e-6, 0, 40};
  auto feed = [&](double t) {
    const Exchange e = exchange(tag, anchor, t, 1e-8, 1e-3, 1e-3);
    return tracker.update("p", static_cast<int64_t>(t * 1e6), e.s.poll_tx, e.s.poll_rx, 40, kTick);
  };
  EXPECT_FALSE(feed(10.0));
  ASSERT_TRUE(feed(10.1));
  EXPECT_NEAR(*feed(10.2) * 1e6, 5.0, 0.01);
  EXPECT_FALSE(feed(20.0));  // 9.8 s later: beyond max_interval_s
  EXPECT_TRUE(feed(20.1));
  EXPECT_FALSE(feed(20.05));  // backwards
  EXPECT_EQ(tracker.tally().restarts, 3);
  // Another pair is separate.
  EXPECT_FALSE(tracker.update("q", 20'200'000, 1, 1, 40, kTick));
}

TEST(ClockOffsetTracker, AnImplausibleOffsetIsCountedNotUsed) {
  ClockOffsetTracker tracker;
  EXPECT_FALSE(tracker.update("p", 1'000'000, 0, 0, 40, kTick));
  // 0.1 s later the anchor advanced 1e7 ticks more than the tag: 1565 ppm.
  const int64_t tag_ticks = static_cast<int64_t>(0.1 / kTick);
  EXPECT_FALSE(tracker.update("p", 1'100'000, tag_ticks, tag_ticks + 10'000'000, 40, kTick));
  EXPECT_EQ(tracker.tally().implausible, 1);
}

// Three consecutive exchanges of uwb-cucudasluv Static_measurements/LOS/height_100.0cm/30m.csv
// (its first three data rows; DW1000, the low 32 bits of each stamp, stored signed): host time, Distance, and
// resp_rx_ts, poll_tx_ts, resp_tx_ts, poll_rx_ts. The interval's offset is about -1.1 ppm, and
// SS-TWR corrected with it lands within 3 cm of the device's Distance; uncorrected, ~20 cm long.
TEST(TwrTimestamps, RealDw1000RowsMatchTheDevicesDistance) {
  struct RealRow {
    double t, distance;
    int64_t resp_rx, poll_tx, resp_tx, poll_rx;
  };
  const RealRow rows[] = {
      {1723715046.1968043, 30.187137, 367489612, 295370668, 632409723, 560303733},
      {1723715046.3393052, 30.205898, -1904415470, -1976534100, -1639505797, -1711611461},
      {1723715046.4824538, 30.243421, 118708115, 46589356, 383607419, 311501637},
  };
  ClockOffsetTracker tracker;
  for (size_t i = 0; i < 3; ++i) {
    const RealRow& row = rows[i];
    Stamps s;
    s.poll_tx = row.poll_tx;
    s.poll_rx = row.poll_rx;
    s.resp_tx = row.resp_tx;
    s.resp_rx = row.resp_rx;
    const Intervals iv = intervals(s, 32);
    const auto r = tracker.update("T1/12", static_cast<int64_t>(std::llround(row.t * 1e6)),
                                  s.poll_tx, s.poll_rx, 32, kDw1000TickS);
    const double unc = ticks_to_m(ss_twr_tof_ticks(iv, 0.0), kDw1000TickS);
    EXPECT_NEAR(unc - row.distance, 0.20, 0.04) << i;
    if (i == 0) {
      EXPECT_FALSE(r.has_value());
      continue;
    }
    ASSERT_TRUE(r.has_value());
    EXPECT_NEAR(*r * 1e6, -1.14, 0.05);
    const double m = ticks_to_m(ss_twr_tof_ticks(iv, *r), kDw1000TickS);
    EXPECT_NEAR(m, row.distance, 0.03) << i;
  }
}

}  // namespace
}  // namespace ips::twr
