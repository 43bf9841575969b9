// The progress line of the log tools: the bar, the percentage, the count and the forecast, and
// nothing at all when the output is not a terminal.
#include "core/progress.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

namespace ips {
namespace {

TEST(ProgressLine, RendersBarPercentCountAndALinearForecast) {
  EXPECT_EQ(ProgressLine::render("ips-replay", 0.42, 4'300'000, 12.0),
            "ips-replay: [########------------]  42 %  4.3 M events  12 s, about 17 s left");
  EXPECT_EQ(ProgressLine::render("ips-export", 0.0, 0, 0.0),
            "ips-export: [--------------------]   0 %  0 events  0 s");
  EXPECT_EQ(ProgressLine::render("ips-sim", 1.0, 12345, 3.25, "messages"),
            "ips-sim: [####################] 100 %  12 k messages  3.2 s");
}

TEST(ProgressLine, ClampsOutOfRangeFractions) {
  EXPECT_EQ(ProgressLine::render("p", -0.5, 1, 0, "x", 4), "p: [----]   0 %  1 x  0 s");
  EXPECT_EQ(ProgressLine::render("p", NAN, 1, 0, "x", 4), "p: [----]   0 %  1 x  0 s");
  EXPECT_EQ(ProgressLine::render("p", 7.0, 1, 0, "x", 4), "p: [####] 100 %  1 x  0.0 s");
}

TEST(ProgressLine, DrawsNothingWhenNotATerminalAndEndsWithOneFullLineWhenForced) {
  std::FILE* quiet = std::tmpfile();
  {
    ProgressLine p("ips-test", quiet);  // a file is not a terminal
    EXPECT_FALSE(p.enabled());
    p.update(0.5, 10);
    p.finish();
  }
  EXPECT_EQ(std::ftell(quiet), 0L);
  std::fclose(quiet);

  std::FILE* out = std::tmpfile();
  {
    ProgressLine p("ips-test", out, /*force=*/true);
    p.update(0.5, 10);  // drawn: the first update always is
    p.update(0.6, 20);  // within 200 ms of the last: skipped
    p.finish();
    p.finish();
  }
  std::rewind(out);
  char buf[512] = {0};
  const size_t n = std::fread(buf, 1, sizeof buf - 1, out);
  std::fclose(out);
  const std::string text(buf, n);
  EXPECT_NE(text.find("\rips-test: [##########----------]  50 %  10 events"), std::string::npos)
      << text;
  EXPECT_EQ(text.find(" 60 %"), std::string::npos) << text;
  EXPECT_NE(text.find("\rips-test: [####################] 100 %  20 events"), std::string::npos)
      << text;
  EXPECT_EQ(text.back(), '\n');
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 1) << "finish() twice ends one line";
}

}  // namespace
}  // namespace ips
