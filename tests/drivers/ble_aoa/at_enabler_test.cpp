// The AT conversation that switches an XPLR-AOA anchor's +UUDF events on
// (drivers/ble_aoa/at_enabler.hpp; commands and answers from the u-blox XPLR-AOA user guide,
// appendix A): what is sent when, waiting for OK, ERROR named, timeouts retried, +STARTUP.
#include "drivers/ble_aoa/at_enabler.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace ips::ble_aoa {
namespace {

using State = AtEnabler::State;

TEST(AtEnabler, BuildsTheCommandList) {
  EXPECT_EQ(AtEnabler::commands_with({}),
            (std::vector<std::string>{"ATE0", "AT+UMLA=1", "AT+UDFENABLE=1"}));
  EXPECT_EQ(AtEnabler::commands_with({"AT+UDFCFG=1,50"}),
            (std::vector<std::string>{"ATE0", "AT+UMLA=1", "AT+UDFCFG=1,50", "AT+UDFENABLE=1"}));
}

TEST(AtEnabler, SendsEachCommandAfterTheOkOfThePreviousOne) {
  AtEnabler at(AtEnabler::commands_with({"AT+UDFCFG=1,50"}));
  EXPECT_EQ(at.state(), State::kClosed);
  EXPECT_EQ(at.poll(0).write, "");
  at.on_open(10.0);
  EXPECT_EQ(at.state(), State::kSettling);
  EXPECT_EQ(at.poll(10.1).write, "");  // settling 0.2 s
  EXPECT_EQ(at.poll(10.25).write, "ATE0\r");
  EXPECT_EQ(at.pending(), "ATE0");
  EXPECT_EQ(at.poll(10.3).write, "");  // waiting
  // Echo is still on for ATE0 itself: the echo is not an answer.
  EXPECT_EQ(at.on_line(AtLine::kEcho, "ATE0", 10.3).write, "");
  EXPECT_EQ(at.on_line(AtLine::kOk, "OK", 10.3).write, "AT+UMLA=1\r");
  const auto said = at.on_line(AtLine::kResponse, "+UMLA:6C1DEBA09862p", 10.4);
  EXPECT_EQ(said.write, "");
  EXPECT_EQ(said.info, "the anchor says +UMLA:6C1DEBA09862p");
  EXPECT_EQ(at.on_line(AtLine::kOk, "OK", 10.4).write, "AT+UDFCFG=1,50\r");
  EXPECT_EQ(at.on_line(AtLine::kOk, "OK", 10.5).write, "AT+UDFENABLE=1\r");
  const auto done = at.on_line(AtLine::kOk, "OK", 10.6);
  EXPECT_EQ(done.write, "");
  EXPECT_EQ(done.info, "+UUDF events enabled");
  EXPECT_EQ(at.state(), State::kEnabled);
  EXPECT_EQ(at.poll(100).write, "");
  EXPECT_EQ(at.on_line(AtLine::kOk, "OK", 101).write, "");  // a stray OK changes nothing
}

TEST(AtEnabler, StopsAtErrorAndNamesTheCommand) {
  AtEnabler at(AtEnabler::commands_with({"AT+UDFCFG=1,50"}));
  at.on_open(0);
  at.poll(0.2);
  at.on_line(AtLine::kOk, "OK", 0.3);
  at.on_line(AtLine::kOk, "OK", 0.4);
  const auto r = at.on_line(AtLine::kError, "ERROR", 0.5);
  EXPECT_EQ(r.write, "");
  EXPECT_EQ(r.failure, "the anchor answered ERROR to AT+UDFCFG=1,50");
  EXPECT_EQ(at.state(), State::kFailed);
  EXPECT_EQ(at.poll(10).write, "");  // no retry after a refusal
}

TEST(AtEnabler, StartsOverWithoutAnAnswerAndGivesUpAfterThreeAttempts) {
  AtEnabler at(AtEnabler::commands_with({}));
  at.on_open(0);
  EXPECT_EQ(at.poll(0.2).write, "ATE0\r");
  EXPECT_EQ(at.attempts(), 1);
  EXPECT_EQ(at.on_line(AtLine::kOk, "OK", 0.3).write, "AT+UMLA=1\r");
  EXPECT_EQ(at.poll(2.2).write, "");         // 1.9 s: still waiting
  EXPECT_EQ(at.poll(2.35).write, "ATE0\r");  // 2 s without an answer: from the top
  EXPECT_EQ(at.attempts(), 2);
  EXPECT_EQ(at.poll(4.4).write, "ATE0\r");
  EXPECT_EQ(at.attempts(), 3);
  const auto r = at.poll(6.5);
  EXPECT_EQ(r.write, "");
  EXPECT_EQ(r.failure, "no answer to ATE0 after 3 attempts; is it an XPLR-AOA anchor?");
  EXPECT_EQ(at.state(), State::kFailed);
}

TEST(AtEnabler, StartsOverAfterTheAnchorRebootsAndAfterAReopen) {
  AtEnabler at(AtEnabler::commands_with({}));
  at.on_open(0);
  at.poll(0.2);
  at.on_line(AtLine::kOk, "OK", 0.3);
  at.on_line(AtLine::kOk, "OK", 0.4);
  at.on_line(AtLine::kOk, "OK", 0.5);
  ASSERT_EQ(at.state(), State::kEnabled);
  const auto r = at.on_line(AtLine::kStartup, "+STARTUP", 5.0);
  EXPECT_EQ(r.info, "anchor restarted (+STARTUP); enabling its events again");
  EXPECT_EQ(at.state(), State::kSettling);
  EXPECT_EQ(at.poll(5.25).write, "ATE0\r");
  at.on_close();
  EXPECT_EQ(at.state(), State::kClosed);
  EXPECT_EQ(at.poll(9).write, "");
  EXPECT_EQ(at.on_line(AtLine::kStartup, "+STARTUP", 9).info, "");  // closed: nothing to do
  at.on_open(10);
  EXPECT_EQ(at.poll(10.25).write, "ATE0\r");
  EXPECT_EQ(at.attempts(), 1);
}

}  // namespace
}  // namespace ips::ble_aoa
