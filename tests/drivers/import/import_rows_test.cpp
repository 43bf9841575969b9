// ips-import's readers: range rows (ROS dump per anchor, tagged libRSF lines, one file for all),
// position rows (quaternion and lever arms, heading, frame transform), dwell intervals, the site
// made from the rows' anchors, and the verdicts that keep an import from being silent.
#include <gtest/gtest.h>

#include <cmath>

#include "core/import_output.hpp"
#include "core/site.hpp"
#include "drivers/import/pose_rows.hpp"
#include "drivers/import/range_rows.hpp"
#include "drivers/import/site_rows.hpp"

namespace ips::import {
namespace {

// Two rows of uwb-cucudasluv's A3.csv (a ROS topic dump, one file per anchor).
constexpr const char* kCucuA3 =
    "%time,field.stamp,field.id,field.x,field.y,field.z,field.distanceFromTag,field.rssi,field.rssi_fp\n"
    "1734501485317590607,1734501485317395687,3,2.5775,0.87,1.97,7.304449333333333,-79.71,-80.75\n"
    "1734501485417273454,1734501485416840553,3,2.5775,0.87,1.97,7.316956666666667,-79.45,-80.72\n";

TEST(RangeRows, RosDumpByHeaderNames) {
  RangeOptions o;
  o.tag = "T1";
  const RangeFile f = read_ranges(kCucuA3, "A3.csv", o);
  ASSERT_EQ(f.error, "");
  ASSERT_EQ(f.ranges.size(), 2u);
  EXPECT_EQ(f.columns, "t,-,anchor,ax,ay,az,range,rx,fp");
  const uwb_range_t& m = f.ranges[0];
  EXPECT_EQ(m.utime, 1734501485317590);  // integer ns to the us below
  EXPECT_EQ(m.tag_id, "T1");
  EXPECT_EQ(m.anchor_id, "3");
  EXPECT_DOUBLE_EQ(m.range_m, 7.304449333333333);
  EXPECT_FLOAT_EQ(m.rx_power_dbm, -79.71f);
  EXPECT_FLOAT_EQ(m.fp_power_dbm, -80.75f);
  EXPECT_TRUE(std::isnan(m.quality));
  EXPECT_EQ(m.seq, 0);
  EXPECT_EQ(f.ranges[1].seq, 1);
  ASSERT_EQ(f.anchors.size(), 1u);
  EXPECT_EQ(f.anchors[0].id, "3");
  EXPECT_DOUBLE_EQ(f.anchors[0].mean(0), 2.5775);
  EXPECT_DOUBLE_EQ(f.anchors[0].mean(2), 1.97);
  EXPECT_TRUE(f.anchors[0].has_z);
  EXPECT_EQ(f.anchors[0].spread(), 0.0);
  EXPECT_NE(f.time_unit.find("ns"), std::string::npos);
}

TEST(RangeRows, NoTagColumnNeedsTag) {
  const RangeFile f = read_ranges(kCucuA3, "A3.csv", {});
  EXPECT_EQ(f.error.rfind("A3.csv: no tag column", 0), 0u) << f.error;
  EXPECT_NE(f.error.find("--tag T"), std::string::npos);
}

TEST(RangeRows, LibRsfTaggedLines) {
  RangeOptions o;
  o.tag = "R1";
  o.read.row_tag = "range2";
  o.columns = "-,t,range,-,ax,ay,anchor";
  const char* text =
      "range2 0.127943992614746 2.95522014829822 0.01 -0.02 -0.01 105 0 \n"
      "odom2diff 0.13 0.1 0.1 0 0.5 0 0 0.01 0.01 0.01\n"
      "range2 0.255912780761719 1.60500394277233 0.01 -0.02 2.365 107 0 \n";
  const RangeFile f = read_ranges(text, "Indoor_UWB_Input.txt", o);
  ASSERT_EQ(f.error, "");
  ASSERT_EQ(f.ranges.size(), 2u);
  EXPECT_EQ(f.tally.skipped, 1);  // the odometry line
  EXPECT_EQ(f.ranges[0].utime, 127944);
  EXPECT_EQ(f.ranges[1].anchor_id, "107");
  EXPECT_TRUE(f.relative_times);
  ASSERT_EQ(f.anchors.size(), 2u);
  EXPECT_FALSE(f.anchors[0].has_z);
  EXPECT_DOUBLE_EQ(f.anchors[1].mean(1), 2.365);
}

TEST(RangeRows, OneFileForAllDefaultLayoutAndUnit) {
  RangeOptions o;
  o.unit = *table::parse_unit("cm", table::Quantity::kLength);
  const RangeFile f = read_ranges("1700000000.5,T1,A1,250\n1700000000.6,T1,A2,310\n"
                                  "1700000000.7,T2,A1,abc\n1700000000.8,T2,A1,-5\n",
                                  "all.csv", o);
  ASSERT_EQ(f.error, "");
  ASSERT_EQ(f.ranges.size(), 2u);
  EXPECT_EQ(f.ranges[0].utime, 1700000000500000);
  EXPECT_DOUBLE_EQ(f.ranges[1].range_m, 3.10);
  EXPECT_EQ(f.tally.bad, 2);
  EXPECT_EQ(f.tally.first_bad_line, 3);
  EXPECT_NE(f.tally.first_bad_reason.find("not a number"), std::string::npos);
  EXPECT_EQ(f.tags, (std::vector<std::string>{"T1"}));
}

TEST(RangeRows, WronglySeparatedFileIsAnErrorWithTheHint) {
  RangeOptions o;
  o.read.separator = ';';
  const RangeFile f = read_ranges("1700000000.5,T1,A1,2.5\n1700000000.6,T1,A2,3.1\n", "x.csv", o);
  EXPECT_NE(f.error.find("0 messages"), std::string::npos) << f.error;
  EXPECT_NE(f.error.find("try --separator ,"), std::string::npos) << f.error;
}

TEST(RangeRows, GarbageIsAnError) {
  const RangeFile f = read_ranges(std::string("\x01\x02garbage\xff\n") + "more nonsense here\n",
                                  "g.bin", {});
  EXPECT_NE(f.error, "");
}

TEST(RangeRows, EmptyFileIsAnError) {
  EXPECT_NE(read_ranges("", "e.csv", {}).error, "");
}

TEST(PoseRows, TrajectoryWithHeadingDegreesAndFloatNanoseconds) {
  PoseOptions o;
  o.tag = "T1";
  const PoseFile f = read_poses(
      "timestamp,x,y,z,heading_degrees\n"
      "1.7345014855003267e+18,-2.5775,-4.25,0.0,0.0\n"
      "1.7345014856253268e+18,-2.577500424675722,-4.249603603939604,0.011,90\n",
      "trajectory.csv", o);
  ASSERT_EQ(f.error, "");
  ASSERT_EQ(f.poses.size(), 2u);
  EXPECT_EQ(f.columns, "t,x,y,z,heading");
  EXPECT_NEAR(static_cast<double>(f.poses[0].utime), 1734501485500327.0, 1.0);
  EXPECT_EQ(f.poses[0].source, "truth");
  EXPECT_EQ(f.poses[0].position_cov[0], 0.0);
  EXPECT_EQ(f.poses[0].status, pose_t::STATUS_OK);
  EXPECT_NEAR(f.poses[1].heading_rad, M_PI / 2, 1e-12);
  EXPECT_DOUBLE_EQ(f.poses[1].position[2], 0.011);
}

TEST(PoseRows, QuaternionLeverArmsGiveEachTagsTruth) {
  PoseOptions o;
  LeverArm a, b;
  ASSERT_EQ(parse_lever_arm("TL=0,0.5,0", a), "");
  ASSERT_EQ(parse_lever_arm("TR=0,-0.5,0.1", b), "");
  o.lever_arms = {a, b};
  // Body at (1, 2, 1), yawed 90 degrees: qw = qz = sqrt(1/2).
  const PoseFile f = read_poses("t,x,y,z,qw,qx,qy,qz\n"
                                "1700000000,1,2,1,0.7071067811865476,0,0,0.7071067811865476\n",
                                "body.csv", o);
  ASSERT_EQ(f.error, "");
  ASSERT_EQ(f.poses.size(), 2u);
  EXPECT_EQ(f.poses[0].tag_id, "TL");
  EXPECT_NEAR(f.poses[0].position[0], 0.5, 1e-12);  // left of a body facing +y is -x
  EXPECT_NEAR(f.poses[0].position[1], 2.0, 1e-12);
  EXPECT_EQ(f.poses[1].tag_id, "TR");
  EXPECT_NEAR(f.poses[1].position[0], 1.5, 1e-12);
  EXPECT_NEAR(f.poses[1].position[2], 1.1, 1e-12);
  EXPECT_NEAR(f.poses[1].heading_rad, M_PI / 2, 1e-12);
  EXPECT_EQ(f.tally.rows, 1);
  EXPECT_EQ(f.tally.messages, 2);
}

TEST(PoseRows, LeverArmWithoutOrientationIsAnError) {
  PoseOptions o;
  o.lever_arms.resize(1);
  o.lever_arms[0].tag = "T1";
  const PoseFile f = read_poses("t,x,y\n1700000000,1,2\n", "p.csv", o);
  EXPECT_NE(f.error.find("--lever-arm needs"), std::string::npos) << f.error;
}

TEST(PoseRows, FrameOffsetAndRotation) {
  PoseOptions o;
  o.tag = "T1";
  o.frame.rotate_rad = M_PI / 2;
  o.frame.offset = Eigen::Vector3d(10, 0, 0);
  o.unit = *table::parse_unit("cm", table::Quantity::kLength);
  const PoseFile f = read_poses("1700000000,100,0\n", "p.csv", o);
  ASSERT_EQ(f.error, "");
  ASSERT_EQ(f.poses.size(), 1u);
  EXPECT_NEAR(f.poses[0].position[0], 10.0, 1e-12);
  EXPECT_NEAR(f.poses[0].position[1], 1.0, 1e-12);
  EXPECT_TRUE(f.planar);
  EXPECT_TRUE(f.poses[0].status & pose_t::STATUS_2D);
}

TEST(PoseRows, LibRsfPointLines) {
  PoseOptions o;
  o.tag = "R1";
  o.read.row_tag = "point2";
  o.columns = "-,t,x,y";
  const PoseFile f = read_poses("point2 0.127943992614746 1.65205474853516 2.2191780090332 0 0 0 0 \n",
                                "gt.txt", o);
  ASSERT_EQ(f.error, "");
  ASSERT_EQ(f.poses.size(), 1u);
  EXPECT_EQ(f.poses[0].utime, 127944);
  EXPECT_DOUBLE_EQ(f.poses[0].position[1], 2.2191780090332);
}

TEST(PoseRows, DwellIntervalsAtARate) {
  eval::DwellFileOptions d;
  const eval::DwellFile dwell = eval::read_dwell_file(
      "StartTimestamp,EndTimestamp,X,Y\n1700000000000,1700000001000,100,200\n", "gt.csv",
      [] {
        eval::DwellFileOptions x;
        x.unit = *table::parse_unit("cm", table::Quantity::kLength);
        return x;
      }());
  PoseOptions o;
  o.tag = "T1";
  const PoseFile f = dwell_poses(dwell, 10.0, o);
  ASSERT_EQ(f.error, "");
  ASSERT_EQ(f.poses.size(), 11u);  // 0, 0.1, ..., 1.0 s
  EXPECT_EQ(f.poses[0].utime, 1700000000000000);
  EXPECT_EQ(f.poses[10].utime, 1700000001000000);
  EXPECT_DOUBLE_EQ(f.poses[5].position[0], 1.0);
  EXPECT_DOUBLE_EQ(f.poses[5].position[1], 2.0);
  EXPECT_EQ(f.poses[5].velocity[0], 0.0);
}

TEST(SiteRows, AnchorsOfTheRowsMakeASite) {
  RangeOptions o;
  o.tag = "T1";
  const RangeFile f = read_ranges(kCucuA3, "A3.csv", o);
  std::vector<AnchorSeen> anchors;
  merge_anchors(anchors, f.anchors);
  merge_anchors(anchors, f.anchors);
  ASSERT_EQ(anchors.size(), 1u);
  EXPECT_EQ(anchors[0].rows, 4);
  const std::string yaml = site_yaml_from_anchors("cucu", anchors, f.tags, {"made by a test"});
  const Site site = parse_site_text(yaml, "test");
  ASSERT_EQ(site.anchors.size(), 1u);
  EXPECT_EQ(site.anchors[0].id, "3");
  EXPECT_DOUBLE_EQ(site.anchors[0].position.x(), 2.5775);
  EXPECT_DOUBLE_EQ(site.anchors[0].position.z(), 1.97);
  ASSERT_EQ(site.tags.size(), 1u);
  EXPECT_TRUE(std::isnan(site.tags[0].height_m));
}

TEST(SiteRows, PlanarAnchorsGiveAPlanarTag) {
  AnchorSeen a;
  a.id = "105";
  a.rows = 1;
  a.sum[0] = -0.02;
  const Site site = parse_site_text(site_yaml_from_anchors("rsf", {a}, {"R1"}, {}), "test");
  ASSERT_EQ(site.tags.size(), 1u);
  EXPECT_EQ(site.tags[0].height_m, 0.0);
}

TEST(SiteRows, Times) {
  EXPECT_EQ(site_times(1'000'000, 12'000'000, 5.0),
            (std::vector<int64_t>{1'000'000, 6'000'000, 11'000'000}));
  EXPECT_EQ(site_times(1'000'000, 12'000'000, 0.0), (std::vector<int64_t>{1'000'000}));
}

// ImportOutput::add_encoded (core, added for ips-import --into): an existing log's events merge
// with new messages by time; at equal times the one added first comes first.
TEST(ImportOutputMerge, EncodedEventsMergeByTime) {
  ImportOutput out;
  const std::vector<uint8_t> a{1, 2, 3}, b{4};
  out.add_encoded("OLD", 200, a.data(), a.size());
  uwb_range_t m;
  m.utime = 100;
  out.add("UWB_RANGE", m);
  out.add_encoded("OLD", 100, b.data(), b.size());
  std::vector<std::pair<std::string, int64_t>> got;
  std::vector<uint8_t> last;
  out.for_each([&](const std::string& ch, int64_t t, const std::vector<uint8_t>& bytes) {
    got.emplace_back(ch, t);
    last = bytes;
  });
  EXPECT_EQ(got, (std::vector<std::pair<std::string, int64_t>>{
                     {"UWB_RANGE", 100}, {"OLD", 100}, {"OLD", 200}}));
  EXPECT_EQ(last, a);
  EXPECT_EQ(out.first_utime(), 100);
  EXPECT_EQ(out.last_utime(), 200);
}

}  // namespace
}  // namespace ips::import
