// LineBuffer: lines split across reads, CRLF/LF/CR endings, overlong lines skipped and counted.
#include "core/line_buffer.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace ips {
namespace {

std::vector<std::string> feed_all(LineBuffer& b, const std::vector<std::string>& chunks) {
  std::vector<std::string> lines;
  for (const auto& c : chunks) b.feed(c, [&](std::string_view l) { lines.emplace_back(l); });
  return lines;
}

TEST(LineBuffer, JoinsLinesSplitAcrossReadsAndAcceptsEveryLineEnding) {
  LineBuffer b;
  const auto lines = feed_all(b, {"DIST,2,AN0,1a2b", ",0.00,0.00,2.50,3.21\r", "\nRANGE T1 A1 4.5\n",
                                  "\r\n\nx\ry\n", "partial"});
  EXPECT_EQ(lines, (std::vector<std::string>{"DIST,2,AN0,1a2b,0.00,0.00,2.50,3.21",
                                             "RANGE T1 A1 4.5", "x", "y"}));
  EXPECT_EQ(b.take_partial(), "partial");
  EXPECT_EQ(b.take_partial(), "");
}

TEST(LineBuffer, SkipsAndCountsOverlongLinesWithoutGrowing) {
  LineBuffer b(8);
  const auto lines = feed_all(b, {"12345678\n", std::string(100000, 'z'), "zz\nok\n", "123456789\n"});
  EXPECT_EQ(lines, (std::vector<std::string>{"12345678", "ok"}));
  EXPECT_EQ(b.overlong_lines(), 2);
}

TEST(LineBuffer, ResetForgetsAPartialLine) {
  LineBuffer b;
  feed_all(b, {"RANGE T1 A"});
  b.reset();
  EXPECT_EQ(feed_all(b, {"RANGE T2 A2 1.0\n"}), (std::vector<std::string>{"RANGE T2 A2 1.0"}));
}

}  // namespace
}  // namespace ips
