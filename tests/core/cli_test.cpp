// The shared command line.
#include "core/cli.hpp"

#include <gtest/gtest.h>

#include "core/channels.hpp"
#include "core/version.hpp"

namespace ips {
namespace {

int parse(std::vector<std::string> args, CommonOptions& opts, bool& go_on) {
  CLI::App app{"test", "prog"};
  add_common_options(app, opts);
  std::vector<char*> argv;
  static std::string prog = "prog";
  argv.push_back(prog.data());
  for (auto& a : args) argv.push_back(a.data());
  int rc = -1;
  go_on = parse_command_line(app, opts, static_cast<int>(argv.size()), argv.data(), rc);
  return rc;
}

TEST(Cli, ChannelOverridesRenameOnlyTheirKind) {
  CommonOptions opts;
  bool go_on = false;
  EXPECT_EQ(parse({"--channel", "POSE_UWB=MY_POSES", "--lcm-url", "memq://", "--site", "s.yaml"},
                  opts, go_on),
            0);
  EXPECT_TRUE(go_on);
  EXPECT_EQ(opts.channel("POSE_UWB"), "MY_POSES");
  EXPECT_EQ(opts.channel("UWB_RANGE"), "UWB_RANGE");
  EXPECT_EQ(opts.lcm_url, "memq://");
  EXPECT_EQ(opts.site_path, "s.yaml");
}

TEST(Cli, MalformedChannelOverrideIsAnError) {
  CommonOptions opts;
  bool go_on = true;
  testing::internal::CaptureStderr();
  EXPECT_EQ(parse({"--channel", "POSE_UWB"}, opts, go_on), 2);
  EXPECT_EQ(testing::internal::GetCapturedStderr(),
            "prog: error: --channel: expected KIND=NAME, got 'POSE_UWB'\n");
  EXPECT_FALSE(go_on);
}

TEST(Cli, UnknownChannelKindIsAnError) {
  CommonOptions opts;
  bool go_on = true;
  testing::internal::CaptureStderr();
  EXPECT_EQ(parse({"--channel", "POSE_UBW=X"}, opts, go_on), 2);
  EXPECT_EQ(testing::internal::GetCapturedStderr().rfind("prog: error: --channel: unknown kind 'POSE_UBW' (UWB_RANGE, ", 0), 0u);
}

TEST(Cli, ChannelNamesThatLcmWouldMisreadAreErrors) {
  for (std::string bad : {std::string("UWB["), std::string("UWB.RANGE"), std::string(64, 'X')}) {
    CommonOptions opts;
    bool go_on = true;
    testing::internal::CaptureStderr();
    EXPECT_EQ(parse({"--channel", "UWB_RANGE=" + bad}, opts, go_on), 2) << bad;
    EXPECT_NE(testing::internal::GetCapturedStderr().find("bad channel name"), std::string::npos);
  }
  EXPECT_TRUE(channel::valid_channel_name(std::string(63, 'X')));
}

TEST(Cli, UnknownLogLevelIsAnError) {
  CommonOptions opts;
  bool go_on = true;
  testing::internal::CaptureStderr();
  EXPECT_EQ(parse({"--log-level", "loud"}, opts, go_on), 2);
  EXPECT_EQ(testing::internal::GetCapturedStderr(),
            "prog: error: --log-level: unknown level 'loud'\n");
}

TEST(Cli, HelpExitsZeroAndListsCommonFlags) {
  CommonOptions opts;
  bool go_on = true;
  testing::internal::CaptureStdout();
  EXPECT_EQ(parse({"--help"}, opts, go_on), 0);
  std::string out = testing::internal::GetCapturedStdout();
  EXPECT_FALSE(go_on);
  for (const char* flag : {"--lcm-url", "--site", "--channel", "--log-level", "--version"})
    EXPECT_NE(out.find(flag), std::string::npos) << flag;
}

// --version answers before a program's own requirements (a required option, a subcommand) are
// checked, as --help does.
TEST(Cli, VersionPrintsOneLineAndExitsZero) {
  CLI::App app{"test", "prog"};
  CommonOptions opts;
  add_common_options(app, opts);
  std::string file;
  app.add_option("--file", file)->required();
  app.add_subcommand("sub", "a subcommand");
  app.require_subcommand(1);
  std::vector<std::string> args = {"prog", "--version"};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  int rc = -1;
  testing::internal::CaptureStdout();
  testing::internal::CaptureStderr();
  EXPECT_FALSE(parse_command_line(app, opts, 2, argv.data(), rc));
  EXPECT_EQ(testing::internal::GetCapturedStderr(), "");
  EXPECT_EQ(testing::internal::GetCapturedStdout(), "prog " + version_text() + "\n");
  EXPECT_EQ(rc, 0);
}

}  // namespace
}  // namespace ips
