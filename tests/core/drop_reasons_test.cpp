// The drop counts by reason that every estimator reports (HEALTH, ips-replay's summary).
#include "core/drop_reasons.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace ips {
namespace {

TEST(DropReasons, CountsPerReasonAndInTotal) {
  DropReasons d;
  EXPECT_EQ(d.total(), 0);
  EXPECT_EQ(d.summary(), "");
  EXPECT_EQ(d.text(), "");
  EXPECT_EQ(d.dominant(), DropReason::kCount);
  d.add(DropReason::kNoSite, 10);
  d.add(DropReason::kGated);
  d.add(DropReason::kGated);
  d.add(DropReason::kCount, 5);  // no reason: ignored, never out of bounds
  EXPECT_EQ(d.count(DropReason::kNoSite), 10);
  EXPECT_EQ(d.count(DropReason::kGated), 2);
  EXPECT_EQ(d.count(DropReason::kLate), 0);
  EXPECT_EQ(d.count(DropReason::kCount), 0);
  EXPECT_EQ(d.total(), 12);
  EXPECT_EQ(d.faults(), 10);  // gated is routine
  EXPECT_EQ(d.dominant(), DropReason::kNoSite);
}

TEST(DropReasons, SummaryIsLargestFirstThenInListOrder) {
  DropReasons d;
  d.add(DropReason::kGated, 2);
  d.add(DropReason::kNoSite, 10);
  d.add(DropReason::kInvalid, 2);  // before kGated in the list: first of the tie
  EXPECT_EQ(d.summary(), "10 no site, 2 invalid, 2 gated");
  EXPECT_EQ(d.text(), "dropped 14: 10 no site, 2 invalid, 2 gated");
  EXPECT_EQ(d.summary(1), "10 no site, and 2 more");
  EXPECT_EQ(d.text(2), "dropped 14: 10 no site, 2 invalid, and 1 more");
}

TEST(DropReasons, EveryReasonHasWords) {
  for (size_t i = 0; i < DropReasons::kNumReasons; ++i) {
    const auto text = drop_reason_text(static_cast<DropReason>(i));
    EXPECT_FALSE(text.empty()) << i;
    EXPECT_NE(text, "?") << i;
  }
  EXPECT_EQ(drop_reason_text(DropReason::kNoAnchorsOfKind), "no anchors of its kind in the site");
  EXPECT_TRUE(drop_reason_is_routine(DropReason::kGated));
  EXPECT_TRUE(drop_reason_is_routine(DropReason::kInitialising));
  EXPECT_FALSE(drop_reason_is_routine(DropReason::kNoSite));
  EXPECT_FALSE(drop_reason_is_routine(DropReason::kInvalid));
}

TEST(DropReasons, AddsUp) {
  DropReasons a, b;
  a.add(DropReason::kLate, 3);
  b.add(DropReason::kLate, 1);
  b.add(DropReason::kDuplicate, 4);
  a += b;
  EXPECT_EQ(a.count(DropReason::kLate), 4);
  EXPECT_EQ(a.count(DropReason::kDuplicate), 4);
  EXPECT_EQ(a.total(), 8);
  EXPECT_FALSE(a == b);
}

// What a live process does with it: the drop counter grows by the new drops; a new fault reports
// the counts as the error (degrading the process), routine drops only count.
struct FakeNode {
  struct {
    int64_t drops = 0;
  } c;
  auto& counters() { return c; }
  std::vector<std::string> errors;
  void report_error(const std::string& text) { errors.push_back(text); }
};

TEST(DropHealth, CountsEveryDropAndReportsFaultsOnly) {
  FakeNode node;
  DropHealth health;
  DropReasons d;
  health.report(node, d);
  EXPECT_EQ(node.c.drops, 0);
  EXPECT_TRUE(node.errors.empty());

  d.add(DropReason::kGated, 2);
  health.report(node, d);
  EXPECT_EQ(node.c.drops, 2);
  EXPECT_TRUE(node.errors.empty());  // outliers: counted, not an error

  d.add(DropReason::kNoSite, 10);
  health.report(node, d);
  EXPECT_EQ(node.c.drops, 12);
  ASSERT_EQ(node.errors.size(), 1u);
  EXPECT_EQ(node.errors.back(), "dropped 12: 10 no site, 2 gated");

  health.report(node, d);  // nothing new: nothing reported
  EXPECT_EQ(node.c.drops, 12);
  EXPECT_EQ(node.errors.size(), 1u);

  d.add(DropReason::kInvalid);
  health.report(node, d, "reference R1 stale");
  EXPECT_EQ(node.c.drops, 13);
  EXPECT_EQ(node.errors.back(), "dropped 13: 10 no site, 2 gated, 1 invalid; reference R1 stale");
}

}  // namespace
}  // namespace ips
