// One colour per channel in every program: the default channels' fixed colours, and colours of
// other names that depend on the name alone.
#include "core/channel_colours.hpp"

#include <gtest/gtest.h>

#include <set>
#include <string>
#include <vector>

#include "core/channels.hpp"

namespace ips {
namespace {

TEST(ChannelColours, DefaultChannelsHaveTheirFixedColours) {
  // TRUTH black, then Tableau 10 (matplotlib's tab10 order: blue, orange, green, red, ...).
  const std::vector<std::pair<const char*, const char*>> want = {
      {channel::kTruth, "#000000"},         {channel::kPoseUwb, "#1f77b4"},
      {channel::kPoseTdoa, "#ff7f0e"},      {channel::kPoseAoa, "#2ca02c"},
      {channel::kPoseFused, "#d62728"},     {channel::kPoseIns, "#9467bd"},
      {channel::kPosePdr, "#8c564b"},       {channel::kInsModule, "#17becf"},
      {channel::kPoseUwbModule, "#bcbd22"}, {channel::kPoseUwbEpoch, "#aec7e8"},
      {channel::kAltitude, "#e377c2"},
  };
  std::vector<std::string> names;
  for (const auto& [name, colour] : want) {
    EXPECT_EQ(channel_colour(name), colour) << name;
    names.push_back(name);
  }
  const auto all = channel_colours(names);
  std::set<std::string> distinct;
  for (const auto& [name, colour] : want) {
    EXPECT_EQ(all.at(name), colour) << name;
    distinct.insert(colour);
  }
  EXPECT_EQ(distinct.size(), want.size());
}

TEST(ChannelColours, OtherNamesKeepTheirColourWhateverElseIsThere) {
  const std::string alone = channel_colours({"POSE_UWB_TEST"}).at("POSE_UWB_TEST");
  EXPECT_EQ(alone, channel_colour("POSE_UWB_TEST"));
  // Not a default channel's colour.
  for (const char* c : {"#000000", "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b",
                        "#17becf", "#bcbd22", "#aec7e8", "#e377c2"})
    EXPECT_NE(alone, c);
  // The same with other channels around, before it in sorted order or after it.
  EXPECT_EQ(channel_colours({"AAA", "POSE_UWB_TEST", "POSE_FUSED"}).at("POSE_UWB_TEST"), alone);
  EXPECT_EQ(channel_colours({"POSE_UWB_TEST", "ZZZ", "TRUTH", "POSE_UWB"}).at("POSE_UWB_TEST"),
            alone);
  EXPECT_EQ(channel_colours({"POSE_UWB_TEST", "POSE_UWB_TEST"}).size(), 1u);
}

TEST(ChannelColours, NamesThatHashAlikeStillGetDistinctColours) {
  // Nine other names fit the nine other colours: some hash alike, all are told apart.
  std::vector<std::string> names;
  for (int i = 0; i < 9; ++i) names.push_back("POSE_TEST_" + std::to_string(i));
  const auto c = channel_colours(names);
  std::set<std::string> distinct;
  size_t own = 0;
  for (const auto& [name, colour] : c) {
    distinct.insert(colour);
    own += colour == channel_colour(name);
  }
  EXPECT_EQ(distinct.size(), names.size());
  EXPECT_LT(own, names.size());  // (the test needs at least one collision to mean anything)
  // The first in sorted order keeps its own colour.
  EXPECT_EQ(c.at("POSE_TEST_0"), channel_colour("POSE_TEST_0"));
}

}  // namespace
}  // namespace ips
