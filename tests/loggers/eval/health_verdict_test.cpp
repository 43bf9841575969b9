// ips-eval --health: one verdict per process from the HEALTH messages of a log.
#include "loggers/eval/health_verdict.hpp"

#include <gtest/gtest.h>

namespace ips::eval {
namespace {

constexpr utime_t kT0 = 1767225600000000;

health_t health(const std::string& source, int32_t pid, int8_t state,
                const std::string& last_error = "", const std::string& note = "") {
  health_t h{};
  h.source = source;
  h.host = "lab1";
  h.pid = pid;
  h.state = state;
  h.last_error = last_error;
  h.note = note;
  h.version = "0.1.0 (git abc, Release)";
  return h;
}

TEST(HealthVerdict, StartingThenOkIsOkAndANoteIsShown) {
  HealthVerdicts v;
  v.add(health("ips-ins", 7, health_t::STATE_STARTING), kT0);
  for (int i = 1; i <= 5; ++i)
    v.add(health("ips-ins", 7, health_t::STATE_OK, "", i >= 3 ? "T1: not a foot IMU" : ""),
          kT0 + i * 1000000);
  ASSERT_EQ(v.processes().size(), 1u);
  const ProcessHealth& p = v.processes()[0];
  EXPECT_STREQ(p.verdict(), "OK");
  EXPECT_EQ(p.messages, 6);
  EXPECT_EQ(p.version, "0.1.0 (git abc, Release)");
  EXPECT_TRUE(v.all_ok());
  EXPECT_EQ(verdict_line(p, kT0),
            "ips-ins              OK        6 HEALTH, all OK after 1 starting; note: T1: not a "
            "foot IMU");
}

TEST(HealthVerdict, ADegradedSpellIsNamedWithItsTimeAndFirstReason) {
  HealthVerdicts v;
  v.add(health("ips-fuse", 9, health_t::STATE_OK), kT0);
  v.add(health("ips-fuse", 9, health_t::STATE_DEGRADED, "T1: 12 gated"), kT0 + 3200000);
  v.add(health("ips-fuse", 9, health_t::STATE_DEGRADED, "T1: 20 gated"), kT0 + 4200000);
  v.add(health("ips-fuse", 9, health_t::STATE_OK, "T1: 20 gated"), kT0 + 5200000);
  v.add(health("ips-twr", 10, health_t::STATE_OK), kT0);
  ASSERT_EQ(v.processes().size(), 2u);
  EXPECT_FALSE(v.all_ok());
  const ProcessHealth& f = v.processes()[0];
  EXPECT_STREQ(f.verdict(), "DEGRADED");
  EXPECT_EQ(verdict_line(f, kT0),
            "ips-fuse             DEGRADED  2 of 4 HEALTH degraded from 3.2 s: T1: 12 gated (OK "
            "again at the end)");
  EXPECT_STREQ(v.processes()[1].verdict(), "OK");
}

TEST(HealthVerdict, ErrorOutranksDegradedAndOnlyStartingIsNotOk) {
  HealthVerdicts v;
  v.add(health("ips-uwb-serial", 3, health_t::STATE_DEGRADED, "slow"), kT0);
  v.add(health("ips-uwb-serial", 3, health_t::STATE_ERROR, "/dev/ttyACM0: gone"), kT0 + 1000000);
  v.add(health("ips-aoa", 4, health_t::STATE_STARTING, "", "waiting for a SITE"), kT0);
  EXPECT_STREQ(v.processes()[0].verdict(), "ERROR");
  EXPECT_EQ(v.processes()[0].last_problem, "/dev/ttyACM0: gone");
  EXPECT_STREQ(v.processes()[1].verdict(), "STARTING");
  EXPECT_EQ(verdict_line(v.processes()[1], kT0),
            "ips-aoa              STARTING  1 HEALTH, never past starting; note: waiting for a SITE");
}

TEST(HealthVerdict, ARestartedProcessIsANewLineAndTextIsMadePrintableAndCut) {
  HealthVerdicts v;
  v.add(health("ips-pdr", 1, health_t::STATE_OK), kT0);
  v.add(health("ips-pdr", 2, health_t::STATE_DEGRADED, std::string("bad\x01") + std::string(300, 'x')),
        kT0 + 1000000);
  ASSERT_EQ(v.processes().size(), 2u);
  const std::string line = verdict_line(v.processes()[1], kT0, 40);
  EXPECT_EQ(line.find('\x01'), std::string::npos);
  EXPECT_EQ(line.substr(line.size() - 3), "...");
  EXPECT_LT(line.size(), 120u);
}

}  // namespace
}  // namespace ips::eval
