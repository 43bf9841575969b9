// Anchor clock synchronisation (estimators/uwb_tdoa/clock_sync.hpp) on noise-free counters built
// by hand: the 40-bit wrap, the time of flight, missed syncs, outliers, re-acquisition, lost
// clocks and the choice of the master. Figures from ../shared/reference/004_uwb_kf.md.
#include "estimators/uwb_tdoa/clock_sync.hpp"

#include <gtest/gtest.h>

#include <map>

#include "estimators/uwb_tdoa/counter_wrap.hpp"
#include "tests/estimators/uwb_tdoa/exact_network.hpp"

namespace ips::uwb_tdoa {
namespace {

using test::ExactNetwork;
using test::kHz;
using test::kStart;

constexpr double kWrapS = kCounterModulusD / kHz;

TEST(TdoaCounterWrap, ModularDifferencesAndWholeWraps) {
  // 004 §1: 5-byte timestamps at 63.8976e9 ticks/s; 0x60757d3fe2 = 6.483624 s; the wrap
  // 2^40 / 63.8976e9 = 17.207 s.
  EXPECT_NEAR(static_cast<double>(0x60757d3fe2) / kHz, 6.483624, 1e-6);
  EXPECT_NEAR(kWrapS, 17.207, 1e-3);
  EXPECT_EQ(counter_diff(int64_t{5}, kCounterModulus - 3), 8);
  EXPECT_EQ(counter_diff(kCounterModulus - 3, int64_t{5}), -8);
  EXPECT_EQ(counter_diff(int64_t{0}, kCounterModulus / 2), -kCounterModulus / 2);
  EXPECT_DOUBLE_EQ(counter_diff(0.25, kCounterModulusD - 0.5), 0.75);
  EXPECT_DOUBLE_EQ(counter_mod(-1.5), kCounterModulusD - 1.5);
  EXPECT_EQ(counter_mod(kCounterModulus + 7), 7);
  EXPECT_FALSE(valid_counter(kCounterModulus));
  EXPECT_FALSE(valid_counter(-1));
  // 40 s elapsed is 2 wraps and 5.586 s: the modular count alone cannot tell, host time can.
  const double elapsed = 40.0 * kHz;
  const double modular = std::fmod(elapsed, kCounterModulusD);
  EXPECT_DOUBLE_EQ(unwrap_near(modular, 40.3 * kHz), elapsed);
  EXPECT_DOUBLE_EQ(unwrap_near(modular, 39.7 * kHz), elapsed);
}

// Feeds a ClockSync and keeps every clock_t it publishes.
struct Harness {
  std::vector<clock_t> out;
  ClockSync sync{[this](const clock_t& c) { out.push_back(c); }, "test"};
  void configure(const ExactNetwork& net, const std::string& params = "") {
    const Site site = net.site(1.2, params);
    ClockSyncParams p;
    const YamlField f = site.estimator_params("uwb_tdoa");
    if (f.defined()) {
      p.master = f.get_string("master", "");
      p.lost_after_s = f.get_double("clock_lost_after_s", p.lost_after_s);
    }
    sync.configure(p, site);
  }
  ExactNetwork::Sink sink() {
    return [this](const uwb_rx_t& m) {
      if (m.is_sync) sync.on_sync(m, m.counter_hz);
    };
  }
  // The last clock_t of an anchor.
  const clock_t* last(const std::string& id) const {
    for (auto it = out.rbegin(); it != out.rend(); ++it)
      if (it->anchor_id == id) return &*it;
    return nullptr;
  }
};

double wrapped(double s) {
  double d = std::fmod(s, kWrapS);
  if (d >= kWrapS / 2) d -= kWrapS;
  if (d < -kWrapS / 2) d += kWrapS;
  return d;
}

// Offset error (s) of the last published estimate of anchor i, and rate error (ppb).
std::pair<double, double> errors(const Harness& h, const ExactNetwork& net, int i) {
  const clock_t* c = h.last(net.anchors()[i].id);
  if (!c) return {NAN, NAN};
  const double t = utime_to_s(c->utime - kStart) - test::kLatencyS;
  return {wrapped(c->offset_s - net.true_offset_s(i, t)), c->rate_ppb - net.true_rate_ppb(i)};
}

TEST(TdoaClockSync, OffsetSubtractsTheMasterToAnchorTimeOfFlight) {
  // 004's example records of one sync (group 034, seq 136): the master 0001 sent at counter
  // 0x3b3e87feb5, anchor 0006 received at 0x611593d9b5. With the anchors at (0, 5) and (5, 0),
  // 7.07 m apart (004 §2.2), the time of flight is 2.357e-8 s.
  const Site site = parse_site_text(
      "anchors:\n  - {id: '0001', kind: uwb_tdoa, position: [0, 5, 0]}\n"
      "  - {id: '0006', kind: uwb_tdoa, position: [5, 0, 0]}\n",
      "site.yaml");
  std::vector<clock_t> out;
  ClockSync sync([&](const clock_t& c) { out.push_back(c); });
  sync.configure({}, site);
  sync.on_sync(ExactNetwork::report(kStart, "0001", "0001", true, 136, 0x3b3e87feb5), kHz);
  sync.on_sync(ExactNetwork::report(kStart, "0006", "0001", true, 136, 0x611593d9b5), kHz);
  EXPECT_EQ(sync.master_id(), "0001");
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].anchor_id, "0001");  // the master's own clock: offset 0 by definition
  EXPECT_EQ(out[0].offset_s, 0.0);
  EXPECT_EQ(out[0].status, 0);
  const double tof = std::sqrt(50.0) / kSpeedOfLightMps;
  EXPECT_NEAR(tof, 2.357e-8, 0.001 * 2.357e-8);  // 004 divides by c = 3e8 m/s, 0.07 % more
  EXPECT_EQ(out[1].anchor_id, "0006");
  EXPECT_EQ(out[1].master_id, "0001");
  EXPECT_NEAR(out[1].offset_s, (6.525657 - 3.982187) - tof, 1e-6);
  EXPECT_NEAR(out[1].offset_s, static_cast<double>(0x611593d9b5 - 0x3b3e87feb5) / kHz - tof,
              20e-12);
  EXPECT_EQ(out[1].status, 1);  // acquiring: one sync gives no rate
  EXPECT_EQ(out[1].num_syncs, 1);
}

TEST(TdoaClockSync, ExactClocksAcrossManyWrapsAreTrackedToTheTick) {
  const ExactNetwork net = test::room_network();
  Harness h;
  h.configure(net);
  std::map<std::string, std::vector<int32_t>> status;
  for (int32_t k = 0; k < 40; ++k) {  // 78 s: every counter wraps 4 or 5 times
    net.sync(h.sink(), k);
    for (int i = 1; i < 5; ++i)
      status[net.anchors()[i].id].push_back(h.last(net.anchors()[i].id)->status);
    if (k >= 3) {
      for (int i = 1; i < 5; ++i) {
        const auto [off, rate] = errors(h, net, i);
        // Rounding to a tick (sigma 4.5 ps) is all the noise there is.
        EXPECT_NEAR(off, 0.0, 20e-12) << net.anchors()[i].id << " sync " << k;
        EXPECT_NEAR(rate, 0.0, 0.02) << net.anchors()[i].id << " sync " << k;
      }
    }
  }
  for (const auto& [id, s] : status) {
    EXPECT_EQ(s[0], 1) << id;  // acquiring
    EXPECT_EQ(s[1], 0) << id;  // tracking from the second sync (offset and rate)
    EXPECT_EQ(s.back(), 0) << id;
  }
  EXPECT_EQ(h.sync.stats().rejected_gate, 0);
  EXPECT_EQ(h.sync.stats().syncs_used, 4 * 40);
  EXPECT_EQ(h.last("A2")->num_syncs, 40);
  EXPECT_EQ(h.last("A1")->num_syncs, 40);  // the master's records
  EXPECT_GT(h.last("A2")->rate_std_ppb, 0.0);
  EXPECT_LT(h.last("A2")->rate_std_ppb, 0.1);
  EXPECT_LT(h.last("A2")->offset_std_s, 0.17e-9);
}

TEST(TdoaClockSync, MissedSyncsArePredictedAcrossEvenBeyondHalfAWrap) {
  // A2 misses syncs 6 to 10: 12 s without one, more than half a wrap (8.6 s), so the elapsed
  // count comes from host time. Its clock is not lost (clock_lost_after_s 30) and stays right.
  const ExactNetwork net = test::room_network();
  Harness h;
  h.configure(net, "{clock_lost_after_s: 30}");
  for (int32_t k = 0; k < 20; ++k)
    net.sync(h.sink(), k, [](int i, int32_t seq) { return !(i == 1 && seq >= 6 && seq <= 10); });
  EXPECT_EQ(h.sync.stats().rejected_gate, 0);
  EXPECT_EQ(h.sync.stats().acquisitions, 4);  // once per anchor: never re-acquired
  EXPECT_EQ(h.last("A2")->num_syncs, 15);
  const auto [off, rate] = errors(h, net, 1);
  EXPECT_NEAR(off, 0.0, 20e-12);
  EXPECT_NEAR(rate, 0.0, 0.02);
}

TEST(TdoaClockSync, OutlierSyncIsGatedAndCounted) {
  // A3's reception of sync 8 is 3 ns late (a reflection): gated, counted, the clock unharmed.
  const ExactNetwork net = test::room_network();
  Harness h;
  h.configure(net);
  for (int32_t k = 0; k < 12; ++k)
    net.sync(h.sink(), k, nullptr, [](int i, int32_t seq, int64_t c) {
      return i == 2 && seq == 8 ? counter_mod(c + 192) : c;  // 192 ticks = 3.0 ns
    });
  EXPECT_EQ(h.sync.stats().rejected_gate, 1);
  EXPECT_EQ(h.sync.stats().reacquisitions, 0);
  EXPECT_EQ(h.last("A3")->num_syncs, 11);
  EXPECT_EQ(h.last("A3")->status, 0);
  const auto [off, rate] = errors(h, net, 2);
  EXPECT_NEAR(off, 0.0, 20e-12);
  EXPECT_NEAR(rate, 0.0, 0.02);
}

TEST(TdoaClockSync, ClockStepIsReacquiredAfterRepeatedRejections) {
  // From sync 8 on, A3's counter reads 15.6 us more (an anchor reset, a counter glitch): the
  // first three are gated, the third restarts the clock from there (acquiring, then tracking).
  ExactNetwork net = test::room_network();
  Harness h;
  h.configure(net);
  const int64_t step = 1'000'000;
  auto alter = [&](int i, int32_t seq, int64_t c) {
    return i == 2 && seq >= 8 ? counter_mod(c + step) : c;
  };
  std::vector<int32_t> status;
  for (int32_t k = 0; k < 16; ++k) {
    net.sync(h.sink(), k, nullptr, alter);
    status.push_back(h.last("A3")->status);
  }
  EXPECT_EQ(h.sync.stats().rejected_gate, 3);
  EXPECT_EQ(h.sync.stats().reacquisitions, 1);
  EXPECT_EQ(status[7], 0);
  EXPECT_EQ(status[10], 1);  // re-acquired at sync 10
  EXPECT_EQ(status[11], 0);  // tracking again from its second sync
  const clock_t* c = h.last("A3");
  const double t = utime_to_s(c->utime - kStart) - test::kLatencyS;
  EXPECT_NEAR(wrapped(c->offset_s - net.true_offset_s(2, t) - step / kHz), 0.0, 20e-12);
  EXPECT_NEAR(c->rate_ppb - net.true_rate_ppb(2), 0.0, 0.05);
}

TEST(TdoaClockSync, SilentAnchorIsLostThenReacquired) {
  const ExactNetwork net = test::room_network();
  Harness h;
  h.configure(net, "{clock_lost_after_s: 7}");
  std::vector<int32_t> status;
  bool converted_while_lost = true;
  for (int32_t k = 0; k < 20; ++k) {
    net.sync(h.sink(), k, [](int i, int32_t seq) { return !(i == 3 && seq >= 5 && seq < 12); });
    status.push_back(h.last("A4")->status);
    // A blink at A4 100 ms after this sync converts only while its clock is tracking.
    const double t = 2.0 * k + 0.1;
    const bool converts =
        h.sync.to_master(3, net.counter(3, t), kStart + s_to_utime(t + test::kLatencyS))
            .has_value();
    if (k == 9) converted_while_lost = converts;
    if (k == 19) {
      EXPECT_TRUE(converts);
    }
  }
  EXPECT_FALSE(converted_while_lost);
  EXPECT_EQ(status[4], 0);
  EXPECT_EQ(status[7], 0);  // 6 s since its last sync: still tracking (predicted)
  EXPECT_EQ(status[8], 2);  // 8 s: lost, reported with every master record
  EXPECT_EQ(status[11], 2);
  EXPECT_EQ(status[12], 1);  // a sync again: acquiring afresh
  EXPECT_EQ(status[14], 0);
  EXPECT_EQ(h.sync.stats().acquisitions, 5);
  const auto [off, rate] = errors(h, net, 3);
  EXPECT_NEAR(off, 0.0, 20e-12);
  EXPECT_NEAR(rate, 0.0, 0.05);
}

TEST(TdoaClockSync, ReceptionsBeforeTheMastersRecordAreMatchedBySeq) {
  // Reports of one sync arrive in any order; an unmatched one expires and is counted.
  const ExactNetwork net = test::room_network();
  Harness h;
  h.configure(net);
  for (int32_t k = 0; k < 6; ++k) {
    std::vector<uwb_rx_t> batch;
    net.sync([&](const uwb_rx_t& m) { batch.push_back(m); }, k);
    for (auto it = batch.rbegin(); it != batch.rend(); ++it) h.sync.on_sync(*it, kHz);
  }
  EXPECT_EQ(h.sync.stats().syncs_used, 4 * 6);
  EXPECT_EQ(h.last("A2")->status, 0);
  // A reception whose master record never comes (seq 99), then time moves on.
  h.sync.on_sync(ExactNetwork::report(kStart + 13'000'000, "A2", "A1", true, 99, 5), kHz);
  net.sync(h.sink(), 7);
  EXPECT_EQ(h.sync.stats().dropped_unmatched, 1);
  // The same master record twice is a duplicate.
  net.sync(h.sink(), 7);
  EXPECT_GE(h.sync.stats().dropped_duplicate, 1);
}

TEST(TdoaClockSync, MasterIsTheSenderUnlessForced) {
  const ExactNetwork net = test::room_network();
  Harness autom;
  autom.configure(net);
  for (int32_t k = 0; k < 4; ++k) net.sync(autom.sink(), k);
  EXPECT_EQ(autom.sync.master_id(), "A1");
  EXPECT_EQ(autom.sync.stats().dropped_other_master, 0);

  Harness forced;
  forced.configure(net, "{master: A2}");
  EXPECT_EQ(forced.sync.master_id(), "A2");
  for (int32_t k = 0; k < 4; ++k) net.sync(forced.sink(), k);
  EXPECT_EQ(forced.sync.stats().dropped_other_master, 4 * 5);
  EXPECT_EQ(forced.sync.stats().syncs_used, 0);
  EXPECT_FALSE(forced.sync.to_master(0, 12345, kStart + 8'000'000).has_value());
}

TEST(TdoaClockSync, AnotherMasterTakesOverWhenTheMasterFallsSilent) {
  // A1 sends syncs for 20 s, then A3 (with A1 silent): after clock_lost_after_s (10 s) of A3's
  // syncs being ignored, A3 becomes the master and every clock is relative to it.
  const ExactNetwork first = test::room_network();
  std::vector<test::TestAnchor> anchors = first.anchors();
  const ExactNetwork second(anchors, 2);
  Harness h;
  h.configure(first);
  for (int32_t k = 0; k < 10; ++k) first.sync(h.sink(), k);
  for (int32_t k = 10; k < 25; ++k) second.sync(h.sink(), k);
  EXPECT_EQ(h.sync.stats().master_changes, 1);
  EXPECT_EQ(h.sync.master_id(), "A3");
  EXPECT_GT(h.sync.stats().dropped_other_master, 0);
  const clock_t* c = h.last("A2");
  ASSERT_NE(c, nullptr);
  EXPECT_EQ(c->master_id, "A3");
  EXPECT_EQ(c->status, 0);
  const auto [off, rate] = errors(h, second, 1);
  EXPECT_NEAR(off, 0.0, 20e-12);
  EXPECT_NEAR(rate, 0.0, 0.05);
}

TEST(TdoaClockSync, HostTimeGoingBackIsDroppedUntilTheCallerRestartsTheClocks) {
  const ExactNetwork net = test::room_network();
  Harness h;
  h.configure(net);
  for (int32_t k = 0; k < 5; ++k) net.sync(h.sink(), k);
  // The same syncs again an hour earlier in host time (a replay restarted, or bogus stamps): on
  // their own, stale; once the estimator's time guard confirms the step, restart().
  auto earlier = [&](int32_t k) {
    net.sync(
        [&](const uwb_rx_t& m) {
          uwb_rx_t e = m;
          e.utime -= 3'600'000'000LL;
          h.sync.on_sync(e, kHz);
        },
        k);
  };
  const int64_t late_before = h.sync.stats().dropped_late;
  earlier(0);
  EXPECT_GT(h.sync.stats().dropped_late, late_before);
  EXPECT_EQ(h.sync.stats().time_resets, 0);
  h.sync.restart();
  for (int32_t k = 0; k < 5; ++k) earlier(k);
  EXPECT_EQ(h.sync.stats().time_resets, 1);
  EXPECT_EQ(h.last("A2")->status, 0);
  EXPECT_EQ(h.last("A2")->num_syncs, 5);
}

}  // namespace
}  // namespace ips::uwb_tdoa
