// The build's version text (--version of every program, health_t.version).
#include "core/version.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>

namespace ips {
namespace {

// The VERSION of CMakeLists.txt's project(), which the generated header must carry.
std::string project_version() {
  std::ifstream in(std::string(IPS_SOURCE_DIR) + "/CMakeLists.txt");
  std::stringstream text;
  text << in.rdbuf();
  std::smatch m;
  const std::string s = text.str();
  if (!std::regex_search(s, m, std::regex(R"(project\(\s*ips_fusion\s+VERSION\s+([0-9.]+))")))
    return "";
  return m[1];
}

TEST(Version, TextIsVersionGitDescribeAndBuildType) {
  const BuildVersion v = build_version();
  EXPECT_EQ(version_text(), v.version + " (git " + v.git + ", " + v.build_type + ")");
  EXPECT_TRUE(std::regex_match(version_text(),
                               std::regex(R"([0-9]+\.[0-9]+\.[0-9]+ \(git [^ ,()]+, [A-Za-z]+\))")))
      << version_text();
  EXPECT_EQ(version_line("ips-uwb-twr"), "ips-uwb-twr " + version_text());
}

TEST(Version, PartsComeFromTheProjectGitAndCMake) {
  const BuildVersion v = build_version();
  ASSERT_FALSE(project_version().empty());
  EXPECT_EQ(v.version, project_version());
  // `git describe --always --dirty --abbrev=12`: the last tag, the commits since and the commit;
  // only the commit when no tag is reachable; only the tag (a version, "v0.2.0") on a tagged
  // commit; "-dirty" when the tree had changes. "unknown" only without git.
  EXPECT_TRUE(std::regex_match(v.git, std::regex(R"((\S+-[0-9]+-g[0-9a-f]{12,40}|[0-9a-f]{12,40})"
                                                 R"(|v?[0-9][0-9A-Za-z.+_-]*|unknown)(-dirty)?)")))
      << v.git;
  if (std::filesystem::exists(std::string(IPS_SOURCE_DIR) + "/.git")) {
    EXPECT_NE(v.git, "unknown");
  }
  EXPECT_TRUE(std::regex_match(v.build_type, std::regex("[A-Za-z]+"))) << v.build_type;
}

}  // namespace
}  // namespace ips
