// The node runtime on LCM's in-process memq provider (the multicast path is covered by the
// integration tests in a network namespace).
#include "core/node.hpp"

#include <gtest/gtest.h>

#include <ips/pose_t.hpp>
#include <ips/site_t.hpp>
#include <ips/uwb_range_t.hpp>

#include "core/lcm_url.hpp"
#include "core/site_source.hpp"
#include "core/version.hpp"

#include <unistd.h>

#include <chrono>
#include <csignal>
#include <thread>
#include <vector>

namespace ips {
namespace {

CommonOptions memq() {
  CommonOptions o;
  o.lcm_url = "memq://";
  return o;
}

TEST(Node, TypedPublishSubscribeCountsMessages) {
  Node node("test", memq());
  std::vector<double> got;
  node.subscribe<uwb_range_t>("R", [&](const uwb_range_t& m, const std::string& ch) {
    EXPECT_EQ(ch, "R");
    got.push_back(m.range_m);
  });
  uwb_range_t m{};
  m.range_m = 4.25;
  node.publish("R", m);
  node.spin_once(100);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0], 4.25);
  EXPECT_EQ(node.counters().msgs_in, 1);
  EXPECT_EQ(node.counters().msgs_out, 1);
}

TEST(Node, WrongTypeOnChannelIsAParseErrorNotACrash) {
  Node node("test", memq());
  int calls = 0;
  node.subscribe<uwb_range_t>("R", [&](const uwb_range_t&, const std::string&) { ++calls; });
  pose_t p{};
  node.lcm().publish("R", &p);
  const uint8_t garbage[5] = {1, 2, 3, 4, 5};
  node.lcm().publish("R", garbage, sizeof garbage);
  node.spin_once(100);
  node.spin_once(100);
  EXPECT_EQ(calls, 0);
  EXPECT_EQ(node.counters().msgs_in, 2);
  EXPECT_EQ(node.counters().parse_errors, 2);
}

// lcm-gen 1.3.1's decoders threw std::length_error on a string length of 0 and allocated for any
// array count before checking it (found by fuzzing); lcmtypes/harden_generated.cmake fixes both.
TEST(DecodeMessage, ZeroOrNegativeStringLengthIsADecodeErrorNotAThrow) {
  uwb_range_t m{};
  m.source = "sim";
  std::vector<uint8_t> buf(static_cast<size_t>(m.getEncodedSize()));
  m.encode(buf.data(), 0, static_cast<int>(buf.size()));
  // Layout: 8-byte fingerprint, 8-byte utime, then the big-endian int32 length of `source`.
  for (uint8_t b : {uint8_t{0x00}, uint8_t{0xff}}) {
    std::vector<uint8_t> bad = buf;
    bad[16] = bad[17] = bad[18] = bad[19] = b;  // length 0, then -1
    uwb_range_t out;
    EXPECT_FALSE(decode_message(out, bad.data(), bad.size()));
  }
  uwb_range_t ok;
  EXPECT_TRUE(decode_message(ok, buf.data(), buf.size()));
  EXPECT_EQ(ok.source, "sim");
}

TEST(DecodeMessage, HugeArrayCountIsRejectedBeforeAllocating) {
  site_t s{};
  s.source = "x";
  s.name = "n";
  s.site_yaml = "y";
  std::vector<uint8_t> buf(static_cast<size_t>(s.getEncodedSize()));
  s.encode(buf.data(), 0, static_cast<int>(buf.size()));
  // fingerprint 8, utime 8, source (4 + 2), name (4 + 2), then num_anchors.
  const size_t at = 8 + 8 + 6 + 6;
  for (uint8_t b : {uint8_t{0x7f}, uint8_t{0xff}}) {
    std::vector<uint8_t> bad = buf;
    bad[at] = b;
    bad[at + 1] = bad[at + 2] = bad[at + 3] = 0xff;  // INT32_MAX, then -1
    site_t out;
    EXPECT_FALSE(decode_message(out, bad.data(), bad.size()));
  }
}

TEST(Node, HealthReportsCountersAndErrors) {
  Node node("healthy", memq());
  std::vector<health_t> health;
  node.subscribe<health_t>("HEALTH", [&](const health_t& h, const std::string&) { health.push_back(h); });
  node.report_error("something broke");
  node.publish_health();
  node.spin_once(100);
  ASSERT_EQ(health.size(), 1u);
  EXPECT_EQ(health[0].source, "healthy");
  EXPECT_EQ(health[0].state, health_t::STATE_DEGRADED);
  EXPECT_EQ(health[0].last_error, "something broke");
  EXPECT_GT(health[0].pid, 0);
  EXPECT_EQ(health[0].version, version_text());
  // Every report carries the build, not only the first: a logger started later records it too.
  node.publish_health();
  node.spin_once(100);
  ASSERT_EQ(health.size(), 2u);
  EXPECT_EQ(health[1].version, version_text());
  EXPECT_NE(health[1].version.find(" (git "), std::string::npos) << health[1].version;
}

// A node that publishes its HEALTH on demand and hands back what came on the bus.
struct HealthTap {
  explicit HealthTap(const std::string& name) : node(name, memq()) {
    node.subscribe<health_t>("HEALTH", [this](const health_t& h, const std::string&) { last = h; });
  }
  health_t publish() {
    node.publish_health();
    node.spin_once(50);
    return last;
  }
  Node node;
  health_t last;
};

TEST(Node, DegradedByAnErrorReturnsToOkAfterTheHoldButAStateSetByHandStays) {
  HealthTap tap("recovering");
  Node& node = tap.node;
  node.set_degraded_hold(0.2);
  // The hold counts from the latest error: a report 0.24 s after the first error (past the
  // hold) and 0.12 s after the latest (within it) is degraded. A loaded machine can overrun a
  // sleep and put the report past the latest's hold too: then that try proves nothing and is
  // made again, with fresh errors.
  using Clock = std::chrono::steady_clock;
  const auto hold = std::chrono::milliseconds(200);
  for (int attempt = 1;; ++attempt) {
    const Clock::time_point first = Clock::now();
    node.report_error("a bad message");
    const Clock::time_point first_done = Clock::now();
    const health_t at_once = tap.publish();
    const bool at_once_timed = Clock::now() - first < hold;
    std::this_thread::sleep_for(std::chrono::milliseconds(120));
    const Clock::time_point latest = Clock::now();
    node.report_error("another");
    std::this_thread::sleep_for(std::chrono::milliseconds(120));
    const Clock::time_point before = Clock::now();
    const health_t later = tap.publish();
    if (at_once_timed && before - first_done > hold && Clock::now() - latest < hold) {
      EXPECT_EQ(at_once.state, health_t::STATE_DEGRADED);
      EXPECT_EQ(later.state, health_t::STATE_DEGRADED);
      break;
    }
    ASSERT_LT(attempt, 50) << "the machine is too loaded to time a 0.2 s hold";
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(150));
  const health_t back = tap.publish();
  EXPECT_EQ(back.state, health_t::STATE_OK);
  EXPECT_EQ(back.last_error, "another");  // the text stays for the record
  // A driver that says its device is down stays degraded, errors or not.
  node.set_state(health_t::STATE_DEGRADED);
  std::this_thread::sleep_for(std::chrono::milliseconds(250));
  EXPECT_EQ(tap.publish().state, health_t::STATE_DEGRADED);
  // A lasting error (a device away) does not wear off, nor does set_state() end it: only the
  // end of every such condition does (two devices: one back is not enough).
  node.set_state(health_t::STATE_OK);
  node.report_lasting_error("/dev/ttyACM0", "device /dev/ttyACM0 gone");
  node.report_lasting_error("/dev/ttyACM1", "device /dev/ttyACM1 gone");
  std::this_thread::sleep_for(std::chrono::milliseconds(250));
  health_t away = tap.publish();
  EXPECT_EQ(away.state, health_t::STATE_DEGRADED);
  EXPECT_EQ(away.last_error, "device /dev/ttyACM1 gone");
  node.set_state(health_t::STATE_OK);  // e.g. the site arrived
  EXPECT_EQ(tap.publish().state, health_t::STATE_DEGRADED);
  node.report_error("a partial line at the unplug");  // degraded by an error meanwhile
  node.end_lasting_error("/dev/ttyACM0");
  EXPECT_EQ(tap.publish().state, health_t::STATE_DEGRADED);
  node.end_lasting_error("/dev/ttyACM0");  // twice: no harm
  node.end_lasting_error("/dev/ttyACM1");
  EXPECT_EQ(tap.publish().state, health_t::STATE_OK);  // every device back: the errors end too
  // A state set by hand is not the lasting conditions' to end.
  node.report_lasting_error("/dev/ttyACM0", "device /dev/ttyACM0 gone");
  node.set_state(health_t::STATE_ERROR);
  node.end_lasting_error("/dev/ttyACM0");
  EXPECT_EQ(tap.publish().state, health_t::STATE_ERROR);
  // An error while starting keeps it starting.
  node.set_state(health_t::STATE_STARTING);
  node.report_error("before the site");
  std::this_thread::sleep_for(std::chrono::milliseconds(250));
  EXPECT_EQ(tap.publish().state, health_t::STATE_STARTING);
}

TEST(Node, AnErrorIsShownInAHealthReportEvenWhenTheReportComesAfterTheHold) {
  // A process stalled past the hold (SIGSTOP, a loaded machine) still says what it reported:
  // the first HEALTH after the error is degraded however late it comes, the next one is OK.
  HealthTap tap("stalled");
  tap.node.set_degraded_hold(0.05);
  tap.node.report_error("a bad message");
  std::this_thread::sleep_for(std::chrono::milliseconds(120));
  EXPECT_EQ(tap.publish().state, health_t::STATE_DEGRADED);
  const health_t after = tap.publish();
  EXPECT_EQ(after.state, health_t::STATE_OK);
  EXPECT_EQ(after.last_error, "a bad message");
}

TEST(Node, TimerFires) {
  Node node("t", memq());
  int ticks = 0;
  node.add_timer(0.01, [&] { ++ticks; });
  for (int i = 0; i < 10 && ticks < 2; ++i) node.spin_once(50);
  EXPECT_GE(ticks, 2);
}

TEST(Node, WatchedFdsAreServedInTheLoopAndCanUnwatchThemselves) {
  Node node("t", memq());
  int p[2];
  ASSERT_EQ(pipe(p), 0);
  std::string got;
  node.watch_fd(p[0], POLLIN, [&](short revents) {
    char buf[16];
    const ssize_t n = read(p[0], buf, sizeof buf);
    if (n > 0) got.append(buf, static_cast<size_t>(n));
    if ((revents & POLLHUP) || n == 0) node.unwatch_fd(p[0]);  // the writer went away
  });
  ASSERT_EQ(write(p[1], "abc", 3), 3);
  node.spin_once(100);
  EXPECT_EQ(got, "abc");
  close(p[1]);
  node.spin_once(100);  // hang-up: the handler unwatches
  got.clear();
  node.spin_once(20);  // not watched any more: no call, no spin
  EXPECT_EQ(got, "");
  close(p[0]);
}

TEST(Node, SigtermEndsRunWithStatusZero) {
  Node node("t", memq());
  node.add_timer(0.01, [] { raise(SIGTERM); });
  EXPECT_EQ(node.run(), 0);
  EXPECT_TRUE(node.stopping());
}

TEST(SiteSource, WaitsForSiteMessageAndReportsStartingMeanwhile) {
  Node node("est", memq());
  std::vector<std::string> sites;
  provide_site(node, [&](const Site& s) { sites.push_back(s.name); });
  std::vector<int8_t> states;
  // memq hands over one message a turn (the SITE_REQUEST provide_site sent comes first).
  auto drain = [&] {
    for (int i = 0; i < 4; ++i) node.spin_once(10);
  };
  node.subscribe<health_t>("HEALTH", [&](const health_t& h, const std::string&) { states.push_back(h.state); });
  node.publish_health();
  drain();
  Site site = parse_site_text("name: hall\nanchors:\n  - {id: A, position: [0, 0, 0]}\n", "x");
  node.publish("SITE", site_to_msg(site, 1, "test"));
  drain();
  node.publish("SITE", site_to_msg(site, 2, "test"));  // same site again: not re-applied
  drain();
  site_t broken = site_to_msg(site, 3, "test");
  broken.site_yaml = "anchors: [";
  node.publish("SITE", broken);
  drain();
  node.publish_health();
  drain();
  ASSERT_EQ(sites.size(), 1u);
  EXPECT_EQ(sites[0], "hall");
  ASSERT_EQ(states.size(), 2u);
  EXPECT_EQ(states[0], health_t::STATE_STARTING);
  EXPECT_EQ(states[1], health_t::STATE_DEGRADED);  // the broken SITE was reported
  EXPECT_EQ(node.counters().parse_errors, 1);
}

TEST(SiteSource, AsksForTheSiteAndOnceItHoldsOneAnswersOthersWithTheSameMessage) {
  Node node("est", memq());
  int got = 0;
  provide_site(node, [&](const Site&) { ++got; });
  std::vector<site_t> requests, answers;
  node.subscribe<site_t>("SITE_REQUEST", [&](const site_t& m, const std::string&) { requests.push_back(m); });
  node.subscribe<site_t>("SITE", [&](const site_t& m, const std::string&) { answers.push_back(m); });
  for (int i = 0; i < 3; ++i) node.spin_once(20);
  ASSERT_EQ(requests.size(), 1u);  // asked at start (no site held: nobody answers)
  EXPECT_EQ(requests[0].source, "est");
  EXPECT_EQ(requests[0].num_anchors, 0);
  EXPECT_TRUE(answers.empty());
  Site site = parse_site_text("name: hall\nanchors:\n  - {id: A, position: [0, 0, 0]}\n", "x");
  site_t sent = site_to_msg(site, 7, "publisher");
  node.publish("SITE", sent);
  for (int i = 0; i < 3; ++i) node.spin_once(20);
  EXPECT_EQ(got, 1);
  // Another process asks: answered with the message as it came (same text and source).
  site_t ask{};
  ask.source = "other";
  ask.num_anchors = ask.num_baro_stations = ask.num_tags = 0;
  node.publish("SITE_REQUEST", ask);
  for (int i = 0; i < 6; ++i) node.spin_once(20);
  ASSERT_EQ(answers.size(), 2u);  // the publisher's, then the answer
  EXPECT_EQ(answers[1].site_yaml, sent.site_yaml);
  EXPECT_EQ(answers[1].source, "publisher");
  EXPECT_EQ(got, 1);  // the answer is the same text: not applied again
}

TEST(LcmUrl, BadUrlThrowsOneClearLine) {
  CommonOptions o;
  o.lcm_url = "bogus://nowhere";
  try {
    Node node("t", o);
    FAIL() << "expected LcmOpenError";
  } catch (const LcmOpenError& e) {
    std::string what = e.what();
    EXPECT_EQ(what.rfind("cannot open LCM URL 'bogus://nowhere': ", 0), 0u) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos);
  }
}

TEST(LcmUrl, EffectiveUrlPrefersFlagThenEnvironment) {
  EXPECT_EQ(effective_lcm_url("memq://"), "memq://");
  setenv("LCM_DEFAULT_URL", "udpm://239.1.2.3:7000?ttl=0", 1);
  EXPECT_EQ(effective_lcm_url(""), "udpm://239.1.2.3:7000?ttl=0");
  unsetenv("LCM_DEFAULT_URL");
  EXPECT_EQ(effective_lcm_url(""), "udpm://239.255.76.67:7667?ttl=0");
}

}  // namespace
}  // namespace ips
