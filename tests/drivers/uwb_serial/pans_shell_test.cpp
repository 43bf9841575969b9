// PansShell: the DWM1001 shell conversation in time (two CRs 0.1 s apart, lec 1 s later, start
// over when no lec line comes, no toggling of a tag already streaming, lec + quit on exit).
#include "drivers/uwb_serial/pans_shell.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace ips::uwb_serial {
namespace {

using State = PansShell::State;

// Everything poll() writes between t0 and t1, stepping 10 ms like the driver's 50 ms timer would.
std::string run(PansShell& s, double t0, double t1) {
  std::string out;
  for (double t = t0; t < t1; t += 0.01) out += s.poll(t);
  return out;
}

TEST(PansShell, OpensTheShellAndStartsLecAfterTheProbe) {
  PansShell s;
  EXPECT_EQ(s.poll(0), "");  // closed: nothing
  s.on_open(100.0);
  EXPECT_EQ(run(s, 100.0, 100.99), "");  // probing: listen only
  EXPECT_EQ(s.poll(101.0), "\r");
  EXPECT_TRUE(s.starting());
  EXPECT_EQ(run(s, 101.0, 101.09), "");
  EXPECT_EQ(s.poll(101.1), "\r");
  EXPECT_EQ(run(s, 101.1, 102.09), "");
  EXPECT_EQ(s.poll(102.1), "lec\r");
  EXPECT_EQ(s.state(), State::kLecSent);
  s.on_data_line();
  EXPECT_EQ(s.state(), State::kStreaming);
  EXPECT_FALSE(s.starting());
  EXPECT_EQ(run(s, 102.1, 200.0), "");
  EXPECT_EQ(s.stop_commands(), (std::vector<std::string>{"lec\r", "quit\r"}));
  EXPECT_EQ(s.attempts(), 1);
}

TEST(PansShell, StartsOverWhenNoLecLineComes) {
  PansShell s;
  s.on_open(0.0);
  EXPECT_EQ(run(s, 0.0, 7.0), "\r\rlec\r");
  EXPECT_EQ(run(s, 7.0, 7.3), "\r\r");  // 5 s after lec (sent at 2.1 s): again
  EXPECT_EQ(s.attempts(), 2);
}

TEST(PansShell, LeavesATagThatIsAlreadyStreamingAlone) {
  PansShell s;
  s.on_open(0.0);
  s.poll(0.5);
  s.on_data_line();  // lec output during the probe
  EXPECT_EQ(run(s, 0.5, 10.0), "");
  EXPECT_EQ(s.stop_commands(), (std::vector<std::string>{"lec\r", "quit\r"}));
}

TEST(PansShell, StopCommandsDependOnWhatWasSent) {
  PansShell s;
  EXPECT_TRUE(s.stop_commands().empty());  // never opened
  s.on_open(0.0);
  EXPECT_TRUE(s.stop_commands().empty());  // nothing sent yet
  s.poll(1.0);
  EXPECT_EQ(s.stop_commands(), (std::vector<std::string>{"quit\r"}));  // shell maybe open
  s.on_close();
  EXPECT_TRUE(s.stop_commands().empty());
  EXPECT_EQ(s.poll(50.0), "");
  s.on_data_line();  // a line after close changes nothing
  EXPECT_EQ(s.state(), State::kClosed);
}

TEST(PansShell, ReopenStartsTheConversationAgain) {
  PansShell s;
  s.on_open(0.0);
  run(s, 0.0, 3.0);
  s.on_data_line();
  s.on_close();
  s.on_open(10.0);
  EXPECT_EQ(s.state(), State::kProbing);
  EXPECT_EQ(run(s, 10.0, 12.2), "\r\rlec\r");
  EXPECT_EQ(s.attempts(), 1);
}

}  // namespace
}  // namespace ips::uwb_serial
