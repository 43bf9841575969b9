// --tags and --shard: which tags an instance of a partitioned site handles (core/tag_selector.hpp,
// core/tag_filter.hpp).
#include "core/tag_selector.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <ips/health_t.hpp>

#include "core/cli.hpp"
#include "core/node.hpp"
#include "core/tag_filter.hpp"

namespace ips {
namespace {

TagSelector make(const std::string& tags, const std::string& shard) {
  std::string error;
  auto sel = TagSelector::parse(tags, shard, error);
  EXPECT_TRUE(sel) << error;
  return sel ? *sel : TagSelector();
}

std::string error_of(const std::string& tags, const std::string& shard) {
  std::string error;
  EXPECT_FALSE(TagSelector::parse(tags, shard, error)) << tags << " " << shard;
  return error;
}

TEST(TagSelector, NothingGivenSelectsEveryTag) {
  TagSelector sel = make("", "");
  EXPECT_TRUE(sel.selects_all());
  EXPECT_TRUE(sel.selects("T1"));
  EXPECT_TRUE(sel.selects(""));
  EXPECT_EQ(sel.describe(), "every tag");
}

TEST(TagSelector, AListSelectsExactlyItsIds) {
  TagSelector sel = make("T1,T2,forklift-7", "");
  EXPECT_TRUE(sel.selects("T1"));
  EXPECT_TRUE(sel.selects("T2"));
  EXPECT_TRUE(sel.selects("forklift-7"));
  EXPECT_FALSE(sel.selects("T10"));  // an id, not a prefix
  EXPECT_FALSE(sel.selects("T"));
  EXPECT_FALSE(sel.selects("t1"));  // case matters
  EXPECT_EQ(sel.describe(), "the tags T1, T2, forklift-7");
  EXPECT_EQ(sel.rejected_ids(), 3);
}

TEST(TagSelector, GlobsWithStarAndQuestionMark) {
  TagSelector sel = make("T1*,B?,*-x", "");
  for (const char* yes : {"T1", "T10", "T1-2", "B1", "Bz", "-x", "cart-x"})
    EXPECT_TRUE(sel.selects(yes)) << yes;
  for (const char* no : {"T2", "B", "B12", "cart-xy", "xT1"}) EXPECT_FALSE(sel.selects(no)) << no;
  EXPECT_TRUE(glob_matches("*", ""));
  EXPECT_TRUE(glob_matches("a*b*c", "aXbYbZc"));
  EXPECT_FALSE(glob_matches("a*b*c", "aXbYbZ"));
  EXPECT_TRUE(glob_matches("**?", "q"));
  EXPECT_FALSE(glob_matches("?", ""));
  // The matcher back-tracks one star at a time: a long text against many stars stays linear-ish.
  EXPECT_FALSE(glob_matches("*a*a*a*a*a*b", std::string(5000, 'a')));
}

// The documented hash (tag_selector.hpp, docs/networking.md): FNV-1a 64 of the id's bytes, mod N,
// plus 1. Reference values of FNV-1a 64 from its authors' test vectors (isthe.com/chongo/tech/
// comp/fnv: "" -> cbf29ce484222325, "a" -> af63dc4c8601ec8c, "foobar" -> 85944171f73967e8).
TEST(TagSelector, TheShardOfAnIdIsFixedAndDocumented) {
  EXPECT_EQ(fnv1a64(""), 0xcbf29ce484222325ull);
  EXPECT_EQ(fnv1a64("a"), 0xaf63dc4c8601ec8cull);
  EXPECT_EQ(fnv1a64("foobar"), 0x85944171f73967e8ull);
  // The example of the header and the docs: T1 -> 1, T2 -> 3, T3 -> 2 of 3.
  EXPECT_EQ(shard_of("T1", 3), 1);
  EXPECT_EQ(shard_of("T2", 3), 3);
  EXPECT_EQ(shard_of("T3", 3), 2);
  EXPECT_EQ(shard_of("T10", 3), 3);
  EXPECT_EQ(shard_of("anything", 1), 1);
  TagSelector two_of_three = make("", "2/3");
  EXPECT_FALSE(two_of_three.selects("T1"));
  EXPECT_FALSE(two_of_three.selects("T2"));
  EXPECT_TRUE(two_of_three.selects("T3"));
  EXPECT_EQ(two_of_three.describe(), "shard 2/3");
}

TEST(TagSelector, TheShardsOfAThousandIdsAreAPartition) {
  for (int n : {1, 2, 3, 7, 16, 1024}) {
    std::vector<TagSelector> shards;
    for (int k = 1; k <= n; ++k)
      shards.push_back(make("", std::to_string(k) + "/" + std::to_string(n)));
    std::vector<int> sizes(static_cast<size_t>(n), 0);
    for (int i = 0; i < 1000; ++i) {
      const std::string id = "T" + std::to_string(i);
      int holders = 0;
      for (int k = 0; k < n; ++k) {
        if (shards[static_cast<size_t>(k)].selects(id)) {
          ++holders;
          ++sizes[static_cast<size_t>(k)];
        }
      }
      ASSERT_EQ(holders, 1) << id << " in " << holders << " of " << n << " shards";
    }
    // Spread: with 3 shards each holds a third give or take 5 standard deviations of a binomial.
    if (n == 3) {
      for (int s : sizes) EXPECT_NEAR(s, 333.3, 5 * std::sqrt(1000 * (1 / 3.0) * (2 / 3.0)));
    }
  }
}

TEST(TagSelector, TagsAndShardTogetherNeedBoth) {
  TagSelector sel = make("T*", "1/3");
  EXPECT_TRUE(sel.selects("T1"));   // T* and shard 1
  EXPECT_FALSE(sel.selects("T3"));  // T* but shard 2
  EXPECT_FALSE(sel.selects("X6"));  // not T*
  EXPECT_EQ(sel.describe(), "shard 1/3 of the tags T*");
}

TEST(TagSelector, StationsAlwaysPass) {
  TagSelector sel = make("T1", "");
  EXPECT_FALSE(sel.selects("A1"));
  sel.set_always_selected({"A1", "REF1"});  // the site's anchors and reference barometers
  EXPECT_TRUE(sel.selects("A1"));
  EXPECT_TRUE(sel.selects("REF1"));
  EXPECT_FALSE(sel.selects("T2"));
}

TEST(TagSelector, BadValuesAreClearErrors) {
  for (const char* bad : {"0/3", "4/3", "1/0", "1/1025", "3", "1/", "/3", "a/b", "1/3/5", "-1/3",
                          " 1/3", "1/3 ", "+1/3", "1.0/3", "99999999999/3"})
    EXPECT_EQ(error_of("", bad).rfind(
                  "--shard: expected K/N with 1 <= K <= N <= 1024 (e.g. 2/3), got '", 0),
              0u)
        << bad;
  EXPECT_EQ(error_of("", "4/3"),
            "--shard: expected K/N with 1 <= K <= N <= 1024 (e.g. 2/3), got '4/3'");
  EXPECT_EQ(error_of("T1,,T2", ""),
            "--tags: an empty item in 'T1,,T2' (expected ids and globs separated by commas, e.g. "
            "T1,T2 or 'T1*')");
  EXPECT_EQ(error_of(",", "").rfind("--tags: an empty item", 0), 0u);
  EXPECT_EQ(error_of("T1, T2", ""), "--tags: ' T2' has a space or control character");
  EXPECT_EQ(make("", "1024/1024").shards(), 1024);
}

int parse(std::vector<std::string> args, CommonOptions& opts, CommonFlags flags) {
  CLI::App app{"test", "prog"};
  add_common_options(app, opts, flags);
  std::vector<char*> argv;
  static std::string prog = "prog";
  argv.push_back(prog.data());
  for (auto& a : args) argv.push_back(a.data());
  int rc = -1;
  parse_command_line(app, opts, static_cast<int>(argv.size()), argv.data(), rc);
  return rc;
}

TEST(TagSelector, TheFlagsAreOfferedOnlyWhereAProgramOptsIn) {
  CommonOptions opts;
  testing::internal::CaptureStderr();
  EXPECT_EQ(parse({"--shard", "1/3"}, opts, {}), 2);  // not offered: CLI11 refuses it
  EXPECT_NE(testing::internal::GetCapturedStderr().find("--shard"), std::string::npos);
  CommonFlags with_tags;
  with_tags.tags = true;
  EXPECT_EQ(parse({"--shard", "2/3", "--tags", "T*"}, opts, with_tags), 0);
  EXPECT_EQ(opts.shard, "2/3");
  EXPECT_EQ(opts.tags, "T*");
  CommonOptions bad;
  testing::internal::CaptureStderr();
  EXPECT_EQ(parse({"--shard", "3/2"}, bad, with_tags), 2);
  EXPECT_EQ(testing::internal::GetCapturedStderr(),
            "prog: error: --shard: expected K/N with 1 <= K <= N <= 1024 (e.g. 2/3), got '3/2'\n");
}

TEST(TagFilter, SkipsOtherTagsCountsThemAndSaysSoInHealth) {
  CommonOptions o;
  o.lcm_url = "memq://";
  o.shard = "1/3";
  Node node("sharded", o);
  TagFilter filter(node, o);
  Site site;
  site.anchors.push_back(Anchor{});
  site.anchors.back().id = "A1";
  filter.set_site(site);
  EXPECT_TRUE(filter.pass("T1"));   // shard 1
  EXPECT_FALSE(filter.pass("T2"));  // shard 3
  EXPECT_FALSE(filter.pass("T2"));
  EXPECT_FALSE(filter.pass("T3"));  // shard 2
  EXPECT_TRUE(filter.pass("A1"));   // an anchor: anchor-to-anchor ranges pass
  EXPECT_EQ(filter.skipped(), 3);
  std::vector<health_t> health;
  node.subscribe<health_t>("HEALTH",
                           [&](const health_t& h, const std::string&) { health.push_back(h); });
  node.report_note("tags", filter.note());
  node.publish_health();
  node.spin_once(100);
  ASSERT_FALSE(health.empty());
  EXPECT_EQ(health.back().note, "shard 1/3: 3 messages of 2 other tags skipped");
  EXPECT_EQ(health.back().state, health_t::STATE_OK);
}

TEST(TagFilter, WithoutTheOptionsEverythingPassesAndNothingIsSaid) {
  CommonOptions o;
  o.lcm_url = "memq://";
  Node node("whole", o);
  TagFilter filter(node, o);
  EXPECT_TRUE(filter.pass("T2"));
  EXPECT_EQ(filter.skipped(), 0);
  EXPECT_EQ(node.note(), "");
}

}  // namespace
}  // namespace ips
