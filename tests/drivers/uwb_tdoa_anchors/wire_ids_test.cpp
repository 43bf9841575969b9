// --id HEX=NAME and the wire ids --to-records gives (drivers/uwb_tdoa_anchors/wire_ids.hpp).
#include "drivers/uwb_tdoa_anchors/wire_ids.hpp"

#include <gtest/gtest.h>

namespace ips::uwb_tdoa_anchors {
namespace {

TEST(WireIds, UnnamedIdsArePublishedAsSent) {
  WireIds ids;
  EXPECT_EQ(ids.name_for("0006"), "0006");
  EXPECT_EQ(ids.name_for("00aB"), "00aB");
  EXPECT_EQ(ids.wire_id_for("0006"), "0006");
  EXPECT_EQ(ids.wire_id_for("A6"), "");
}

TEST(WireIds, NamesBothWaysCaseInsensitively) {
  WireIds ids;
  EXPECT_EQ(ids.add("000A=A10"), "");
  EXPECT_EQ(ids.add("1001=T1"), "");
  EXPECT_EQ(ids.name_for("000a"), "A10");
  EXPECT_EQ(ids.name_for("000A"), "A10");
  EXPECT_EQ(ids.name_for("1001"), "T1");
  EXPECT_EQ(ids.wire_id_for("A10"), "000A");
  EXPECT_EQ(ids.wire_id_for("T1"), "1001");
  EXPECT_EQ(ids.wire_id_for("000A"), "");  // a named hex id stands for its name only
  EXPECT_EQ(ids.wire_id_for("0002"), "0002");
}

TEST(WireIds, RefusesBadSpecs) {
  WireIds ids;
  EXPECT_NE(ids.add("0006"), "");
  EXPECT_NE(ids.add("006=A6"), "");
  EXPECT_NE(ids.add("0006="), "");
  EXPECT_NE(ids.add("0006=A 6"), "");
  EXPECT_NE(ids.add("0006=0007"), "");  // published like the other wire id
  EXPECT_EQ(ids.add("0006=A6"), "");
  EXPECT_NE(ids.add("0006=B6"), "");
  EXPECT_NE(ids.add("0007=A6"), "");
  EXPECT_NE(ids.add("0006=" + std::string(33, 'a')), "");
}

TEST(WireIds, AssignsAnchorsFrom0001AndTagsFrom1001SkippingTakenIds) {
  WireIds ids;
  ASSERT_EQ(ids.add("0002=A9"), "");
  std::string error;
  const auto added = ids.assign_missing({"A1", "A4", "A9", "0001"}, {"T1", "1001"}, error);
  EXPECT_EQ(error, "");
  // 0001 appears as itself and 0002 is A9's: A1 and A4 get 0003 and 0004 (sorted names); T1
  // skips 1001, which appears as itself.
  ASSERT_EQ(added.size(), 3u);
  EXPECT_EQ(added[0], "0003=A1");
  EXPECT_EQ(added[1], "0004=A4");
  EXPECT_EQ(added[2], "1002=T1");
  EXPECT_EQ(ids.wire_id_for("A1"), "0003");
  EXPECT_EQ(ids.name_for("1002"), "T1");
  EXPECT_EQ(ids.wire_id_for("0001"), "0001");
}

TEST(WireIds, ReportsWhenTheIdsRunOut) {
  WireIds ids;
  std::set<std::string> many;
  for (int i = 0; i < 4096; ++i) many.insert("N" + std::to_string(i));
  std::string error;
  const auto added = ids.assign_missing(many, {}, error);
  EXPECT_EQ(added.size(), 4095u);  // 0001..0fff
  EXPECT_NE(error.find("no free wire id"), std::string::npos);
}

}  // namespace
}  // namespace ips::uwb_tdoa_anchors
