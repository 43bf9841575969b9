#include "loggers/export/log_export.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <ips/health_t.hpp>
#include <ips/pose_t.hpp>
#include <ips/site_t.hpp>
#include <ips/uwb_range_t.hpp>
#include <ips/uwb_twr_timestamps_t.hpp>
#include <limits>
#include <vector>

namespace ips::log_export {
namespace {

template <class Msg>
std::vector<uint8_t> encode(const Msg& m) {
  std::vector<uint8_t> buf(static_cast<size_t>(m.getEncodedSize()));
  m.encode(buf.data(), 0, static_cast<int>(buf.size()));
  return buf;
}

uwb_range_t a_range() {
  uwb_range_t m;
  m.utime = 1767225600001000;
  m.source = "ips-sim";
  m.tag_id = "T1";
  m.anchor_id = "A1";
  m.range_m = 2.670367134812347;
  m.rx_power_dbm = -81.5f;
  m.fp_power_dbm = std::nanf("");
  m.quality = 0.1f;
  m.seq = -1;
  return m;
}

TEST(LogExport, UwbRangeGivesHeaderWithUnitsAndOneRow) {
  const auto bytes = encode(a_range());
  const auto d = decode_any(bytes.data(), bytes.size());
  ASSERT_TRUE(d);
  EXPECT_EQ(d->type, "uwb_range_t");
  EXPECT_EQ(csv_line(*d->columns),
            "utime_us,source,tag_id,anchor_id,range_m,rx_power_dbm,fp_power_dbm,quality,seq\n");
  ASSERT_EQ(d->rows.size(), 1u);
  EXPECT_EQ(csv_line(d->rows[0]),
            "1767225600001000,ips-sim,T1,A1,2.670367134812347,-81.5,NaN,0.1,-1\n");
  EXPECT_EQ(json_line("UWB_RANGE", 42, *d),
            "{\"channel\": \"UWB_RANGE\", \"log_time_us\": 42, \"type\": \"uwb_range_t\", "
            "\"utime_us\": 1767225600001000, \"source\": \"ips-sim\", \"tag_id\": \"T1\", "
            "\"anchor_id\": \"A1\", \"range_m\": 2.670367134812347, \"rx_power_dbm\": -81.5, "
            "\"fp_power_dbm\": null, \"quality\": 0.1, \"seq\": -1}\n");
}

TEST(LogExport, TagIdWithCommaQuoteAndNewlineIsQuotedPerRfc4180) {
  auto m = a_range();
  m.tag_id = "T,1 \"x\"\nend";
  const auto bytes = encode(m);
  const auto d = decode_any(bytes.data(), bytes.size());
  ASSERT_TRUE(d);
  EXPECT_EQ(csv_line(d->rows[0]),
            "1767225600001000,ips-sim,\"T,1 \"\"x\"\"\nend\",A1,2.670367134812347,-81.5,NaN,0.1,-1\n");
  EXPECT_NE(json_line("C", 0, *d).find("\"tag_id\": \"T,1 \\\"x\\\"\\u000aend\""),
            std::string::npos);
  EXPECT_EQ(csv_quote("plain"), "plain");
  EXPECT_EQ(csv_quote("a\rb"), "\"a\rb\"");
}

TEST(LogExport, NumbersRoundTrip) {
  for (double v : {0.1, 1.0 / 3.0, 6.02214076e23, -2.2250738585072014e-308, 1767225600.000001}) {
    EXPECT_EQ(std::stod(format_number(v)), v) << format_number(v);
  }
  EXPECT_EQ(std::stof(format_number(0.1f)), 0.1f);
  EXPECT_EQ(format_number(0.1f), "0.1");  // float's own shortest digits, not 0.10000000149
  EXPECT_EQ(format_number(std::numeric_limits<double>::quiet_NaN()), "NaN");
  EXPECT_EQ(format_number(-std::numeric_limits<double>::infinity()), "-Inf");
}

TEST(LogExport, PoseCovarianceFlattenedRowMajor) {
  pose_t m{};
  m.source = "uwb_twr";
  m.tag_id = "T1";
  for (int i = 0; i < 9; ++i) m.position_cov[i] = i;
  const auto bytes = encode(m);
  const auto d = decode_any(bytes.data(), bytes.size());
  ASSERT_TRUE(d);
  EXPECT_EQ(d->type, "pose_t");
  const auto& c = *d->columns;
  ASSERT_EQ(c.size(), d->rows[0].size());
  EXPECT_EQ(c[3], "position_x_m");
  EXPECT_EQ(c[6], "position_cov_xx_m2");
  EXPECT_EQ(c[7], "position_cov_xy_m2");
  EXPECT_EQ(c[14], "position_cov_zz_m2");
  EXPECT_EQ(std::get<double>(d->rows[0][7]), 1.0);
}

TEST(LogExport, SiteHasOneRowPerElementAndYamlInJsonOnly) {
  site_t s{};
  s.source = "ips-sim";
  s.name = "lab";
  anchor_t a{};
  a.id = "A1";
  a.kind = "uwb";
  a.position[2] = 2.4;
  a.enabled = 1;
  s.anchors = {a, a};
  s.num_anchors = 2;
  tag_t t;
  t.id = "T1";
  t.height_m = 1.2;
  s.tags = {t};
  s.num_tags = 1;
  s.site_yaml = "name: lab\nanchors: []\n";
  const auto bytes = encode(s);
  const auto d = decode_any(bytes.data(), bytes.size());
  ASSERT_TRUE(d);
  EXPECT_EQ(d->type, "site_t");
  ASSERT_EQ(d->rows.size(), 3u);
  for (const auto& r : d->rows) EXPECT_EQ(r.size(), d->columns->size());
  EXPECT_EQ(csv_line(d->rows[2]), "0,ips-sim,lab,tag,T1,,NaN,NaN,NaN,NaN,NaN,NaN,1,1.2\n");
  const std::string j = json_line("SITE", 0, *d);
  EXPECT_NE(j.find("\"site_yaml\": \"name: lab\\u000aanchors: []\\u000a\""), std::string::npos);
  EXPECT_NE(j.find("\"enabled\": true"), std::string::npos);
  EXPECT_EQ(j.back(), '\n');
  EXPECT_EQ(j.find('\n'), j.size() - 1);  // one line
}

TEST(LogExport, UnknownTypeAndCorruptBytesAreNotDecoded) {
  const std::vector<uint8_t> junk(64, 0xab);
  EXPECT_FALSE(decode_any(junk.data(), junk.size()));
  EXPECT_FALSE(decode_any(nullptr, 0));
  auto bytes = encode(a_range());
  bytes.resize(bytes.size() - 3);  // cut short: the fingerprint matches, the body does not
  EXPECT_FALSE(decode_any(bytes.data(), bytes.size()));
}

TEST(LogExport, EveryKnownTypeDecodesToARectangularRow) {
  health_t h{};
  h.last_error = "x";
  const auto bytes = encode(h);
  const auto d = decode_any(bytes.data(), bytes.size());
  ASSERT_TRUE(d);
  EXPECT_EQ(d->type, "health_t");
  EXPECT_EQ(d->rows[0].size(), d->columns->size());
  EXPECT_EQ(known_types().size(), 15u);
}

TEST(LogExport, TwrTimestampsExportTheirStampsByName) {
  uwb_twr_timestamps_t x{};
  x.source = "s";
  x.tag_id = "T1";
  x.anchor_id = "12";
  x.n_stamps = 4;
  x.stamps[0] = -1976534100;
  x.stamps[3] = 4294967295;
  x.clock_offset_ppm = -1.14;
  x.range_m = 30.2;
  x.reported_range_m = std::nan("");
  const auto bytes = encode(x);
  const auto d = decode_any(bytes.data(), bytes.size());
  ASSERT_TRUE(d);
  EXPECT_EQ(d->type, "uwb_twr_timestamps_t");
  ASSERT_EQ(d->rows.size(), 1u);
  EXPECT_EQ(csv_line(*d->columns),
            "utime_us,source,tag_id,anchor_id,seq,tick_s,counter_bits,n_stamps,poll_tx,poll_rx,"
            "resp_tx,resp_rx,final_tx,final_rx,clock_offset_ppm,range_m,reported_range_m\n");
  EXPECT_EQ(csv_line(d->rows[0]), "0,s,T1,12,0,0,0,4,-1976534100,0,0,4294967295,0,0,-1.14,30.2,NaN\n");
}

TEST(LogExport, FileStemCannotLeaveTheOutputDirectory) {
  EXPECT_EQ(file_stem("UWB_RANGE"), "UWB_RANGE");
  EXPECT_EQ(file_stem("../etc/passwd"), "_.._etc_passwd");
  EXPECT_EQ(file_stem(".."), "_..");
  EXPECT_EQ(file_stem(""), "_");
  EXPECT_EQ(file_stem("A B/C"), "A_B_C");
}

}  // namespace
}  // namespace ips::log_export
