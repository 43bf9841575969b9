// A note in HEALTH: what a process in good health has to say (issue 23: ips-ins on a hand-held
// phone says why it publishes nothing and stays OK).
#include <gtest/gtest.h>

#include <vector>

#include "core/node.hpp"

namespace ips {
namespace {

TEST(NodeNote, ANoteIsSaidInHealthWithoutChangingTheState) {
  CommonOptions o;
  o.lcm_url = "memq://";
  Node node("noted", o);
  std::vector<health_t> health;
  node.subscribe<health_t>("HEALTH",
                           [&](const health_t& h, const std::string&) { health.push_back(h); });
  auto publish = [&] {
    node.publish_health();
    node.spin_once(100);
    return health.back();
  };
  EXPECT_EQ(publish().note, "");
  node.report_note("b", "T2: not a foot IMU");
  node.report_note("a", "T1: not a foot IMU");
  health_t h = publish();
  EXPECT_EQ(h.state, health_t::STATE_OK);
  EXPECT_EQ(h.note, "T1: not a foot IMU; T2: not a foot IMU");  // by key
  EXPECT_EQ(h.last_error, "");
  node.report_note("a", "T1: not a foot IMU (12 s)");  // a changed text replaces the old
  node.end_note("b");
  EXPECT_EQ(publish().note, "T1: not a foot IMU (12 s)");
  // A fault is a fault beside a note.
  node.report_lasting_error("x", "device gone");
  h = publish();
  EXPECT_EQ(h.state, health_t::STATE_DEGRADED);
  EXPECT_EQ(h.note, "T1: not a foot IMU (12 s)");
  node.end_lasting_error("x");
  node.end_note("a");
  h = publish();
  EXPECT_EQ(h.state, health_t::STATE_OK);
  EXPECT_EQ(h.note, "");
  EXPECT_EQ(node.note(), "");
}

}  // namespace
}  // namespace ips
