// Files of decoded +UUDF fields (drivers/ble_aoa/uudf_table.hpp). The rows are written by hand in
// the layouts of the two public BLE AoA datasets (Byongho96/ble-localization: 2025 files with
// Tag/Anchor MACs and a sequence, 2022 files with numeric ids and two RSSIs), not copied from them.
#include "drivers/ble_aoa/uudf_table.hpp"

#include <gtest/gtest.h>

#include <vector>

namespace ips::ble_aoa {
namespace {

struct Decoded {
  std::vector<ble_aoa_t> msgs;
  table::ImportTally tally;
  std::string columns;
};

Decoded decode(const std::vector<std::string>& lines, UudfTableOptions options = {},
               EventDecoderConfig config = {}) {
  Decoded d;
  config.source = "ips-ble-aoa:a1.csv";
  UudfTableDecoder decoder(std::move(options), std::move(config),
                           [&](const ble_aoa_t& m) { d.msgs.push_back(m); });
  for (const std::string& l : lines) decoder.decode(l);
  d.tally = decoder.tally();
  d.columns = decoder.columns();
  return d;
}

TEST(UudfTable, HeaderWithUnitsMapsByName) {
  const Decoded d = decode({
      "Timestamp(ms),Tag(MAC),RSSI,Azimuth,Elevation,Channel,Anchor(MAC),Sequence",
      "1742248940709,6C1DEBA3FFAC,-57,-5,-20,20,6C1DEBA09949,37107",
      "1742248940711,6C1DEBA3FFAC,-52,-6,-21,27,6C1DEBA09949,37108",
  });
  ASSERT_EQ(d.msgs.size(), 2u);
  EXPECT_EQ(d.tally.rows, 2);
  EXPECT_EQ(d.tally.bad, 0);
  EXPECT_EQ(d.tally.preamble, 1);
  EXPECT_EQ(d.columns, "t,tag,rssi,azimuth,elevation,channel,anchor,seq");
  const ble_aoa_t& m = d.msgs[0];
  EXPECT_EQ(m.utime, 1742248940709000);
  EXPECT_EQ(m.tag_id, "6C1DEBA3FFAC");
  EXPECT_EQ(m.anchor_id, "6C1DEBA09949");
  EXPECT_FLOAT_EQ(m.rssi_dbm, -57);
  EXPECT_FLOAT_EQ(m.azimuth_deg, -5);
  EXPECT_FLOAT_EQ(m.elevation_deg, -20);
  EXPECT_EQ(m.channel, 20);
  EXPECT_EQ(m.seq, 37107);
  EXPECT_EQ(m.source, "ips-ble-aoa:a1.csv");
  EXPECT_EQ(d.msgs[1].seq, 37108);
}

TEST(UudfTable, HeaderInAnotherOrder) {
  const Decoded d = decode({
      "anchor,tag,time,azimuth,elevation,rssi",
      "A7,T3,2025-03-17T22:02:20.709Z,10,5,-60",
  });
  ASSERT_EQ(d.msgs.size(), 1u);
  EXPECT_EQ(d.msgs[0].anchor_id, "A7");
  EXPECT_EQ(d.msgs[0].tag_id, "T3");
  EXPECT_EQ(d.msgs[0].utime, 1742248940709000);
  EXPECT_EQ(d.msgs[0].seq, -1);
}

TEST(UudfTable, NoHeaderDetectsTheNewerLayout) {
  const Decoded d = decode({"1742248940709,6C1DEBA3FFAC,-57,-5,-20,20,6C1DEBA09949,37107"});
  ASSERT_EQ(d.msgs.size(), 1u);
  EXPECT_EQ(d.columns, "t,tag,rssi,azimuth,elevation,channel,anchor,seq");
  EXPECT_EQ(d.msgs[0].channel, 20);
  EXPECT_EQ(d.msgs[0].seq, 37107);
}

TEST(UudfTable, NoHeaderDetectsTheOlderLayoutWithNumericIds) {
  // Timestamp,TagID,1stP,Azimuth,Elevation,2ndP,Channel,AnchorID: the sixth field is an RSSI.
  const Decoded d = decode({"1670598712042,8401,-70,-32,-12,-75,37,6502",
                            "1670598712045,8401,-68,-24,34,-66,39,6501"});
  ASSERT_EQ(d.msgs.size(), 2u);
  EXPECT_EQ(d.columns, "t,tag,rssi,azimuth,elevation,rssi2,channel,anchor");
  EXPECT_EQ(d.msgs[0].tag_id, "8401");
  EXPECT_EQ(d.msgs[0].anchor_id, "6502");
  EXPECT_EQ(d.msgs[0].channel, 37);
  EXPECT_FLOAT_EQ(d.msgs[1].elevation_deg, 34);
}

TEST(UudfTable, OlderHeaderNames) {
  const Decoded d = decode({"Timestamp,TagID,1stP,Azimuth,Elevation,2ndP,Channel,AnchorID",
                            "1670598712042,8401,-70,-32,-12,-75,37,6502"});
  ASSERT_EQ(d.msgs.size(), 1u);
  EXPECT_EQ(d.columns, "t,tag,rssi,azimuth,elevation,rssi2,channel,anchor");
  EXPECT_FLOAT_EQ(d.msgs[0].rssi_dbm, -70);
}

TEST(UudfTable, ColumnsListAndTimeUnit) {
  UudfTableOptions o;
  o.columns = "anchor,-,t,azimuth,elevation,tag";
  o.time_unit = table::TimeUnit::kS;
  o.read.separator = ';';
  const Decoded d = decode({"A1;x;1742248940.5;12;-3;T1"}, o);
  ASSERT_EQ(d.msgs.size(), 1u);
  EXPECT_EQ(d.msgs[0].utime, 1742248940500000);
  EXPECT_EQ(d.msgs[0].anchor_id, "A1");
}

TEST(UudfTable, WholeUudfLinesWithDoubledQuotes) {
  const Decoded d = decode({
      "Timestamp,Data",
      "2025-04-21T21:59:30.156096,\"+UUDF:6C1DEBA3FFAC,-69,16,-7,0,17,\"\"6C1DEBA09949\"\",\"\"\"\","
      "4336143,5778\"",
  });
  ASSERT_EQ(d.msgs.size(), 1u) << d.tally.first_bad_reason;
  EXPECT_EQ(d.msgs[0].utime, 1745272770156096);
  EXPECT_EQ(d.msgs[0].anchor_id, "6C1DEBA09949");
  EXPECT_EQ(d.msgs[0].anchor_uptime_ms, 4336143);
  EXPECT_EQ(d.msgs[0].seq, 5778);
}

TEST(UudfTable, NamesAndDuplicatesThroughTheEventDecoder) {
  EventDecoderConfig c;
  c.anchor_names = {{"6C1DEBA09949", "A1"}};
  c.tag_names = {{"6C1DEBA3FFAC", "T1"}};
  const Decoded d = decode({"1742248940709,6C1DEBA3FFAC,-57,-5,-20,20,6C1DEBA09949,37107",
                            "1742248940709,6C1DEBA3FFAC,-57,-5,-20,20,6C1DEBA09949,37107"},
                           {}, c);
  ASSERT_EQ(d.msgs.size(), 1u);  // the same counter twice: a duplicate
  EXPECT_EQ(d.msgs[0].anchor_id, "A1");
  EXPECT_EQ(d.msgs[0].tag_id, "T1");
  EXPECT_EQ(d.tally.rows, 2);
  EXPECT_EQ(d.tally.messages, 1);
}

TEST(UudfTable, BadRowsAreCountedWithTheFirstReason) {
  const Decoded d = decode({
      "Timestamp,Tag,RSSI,Azimuth,Elevation,Channel,Anchor,Sequence",
      "1742248940709,6C1DEBA3FFAC,-57,-5,-20,20,6C1DEBA09949,1",
      "1742248940710,6C1DEBA3FFAC,-57,-5,-20,45,6C1DEBA09949,2",
      "1742248940711,6C1DEBA3FFAC,-57,200,-20,20,6C1DEBA09949,3",
      "1742248940712,6C1D EBA3,-57,-5,-20,20,6C1DEBA09949,4",
      "42,6C1DEBA3FFAC,-57,-5,-20,20,6C1DEBA09949,5",
      "1742248940713,6C1DEBA3FFAC,-57",
  });
  EXPECT_EQ(d.msgs.size(), 1u);
  EXPECT_EQ(d.tally.bad, 5);
  EXPECT_EQ(d.tally.first_bad_line, 3);
  EXPECT_EQ(d.tally.first_bad_reason, "channel '45' is not a BLE channel 0..39");
}

TEST(UudfTable, TimeNotEpochIsRejected) {
  const Decoded d = decode({"12.5,T1,-57,-5,-20,20,A1,1"});
  EXPECT_TRUE(d.msgs.empty());
  EXPECT_EQ(d.tally.first_bad_reason,
            "time '12.5' is not a Unix epoch time in s, ms, us or ns (give --time-unit)");
}

TEST(UudfTable, HeaderWithoutTheNeededColumnsSaysSo) {
  const Decoded d = decode({"Azimuth_Var,Error_Mean", "1589.4,-22.6"});
  EXPECT_TRUE(d.msgs.empty());
  EXPECT_EQ(d.tally.bad, 1);
  EXPECT_NE(d.tally.first_bad_reason.find("lacks a column of t, tag, azimuth, elevation, anchor"),
            std::string::npos)
      << d.tally.first_bad_reason;
}

TEST(UudfTable, WronglySeparatedFileGetsTheSeparatorHint) {
  UudfTableOptions o;
  o.read.separator = ';';
  UudfTableDecoder decoder(o, {}, nullptr);
  decoder.decode("1742248940709,6C1DEBA3FFAC,-57,-5,-20,20,6C1DEBA09949,37107");
  const std::string verdict = table::import_verdict(decoder.tally(), decoder.expectation("a.csv"));
  EXPECT_NE(verdict.find("looks comma-separated: try --separator ,"), std::string::npos) << verdict;
}

TEST(UudfTable, TellsCaptureLinesApart) {
  EXPECT_TRUE(looks_like_capture_line(
      "2023-12-12 9:50:26.643,COM8,+UUDF:6C1DEBA5F60C,-68,-30,42,0,37,\"6C1DEBA09862\",\"\","
      "1606101,25"));
  EXPECT_TRUE(looks_like_capture_line("\xef\xbb\xbf" "2023-12-12 9:50:27.000,COM8,OK"));
  EXPECT_FALSE(looks_like_capture_line("Timestamp,Tag,RSSI,Azimuth,Elevation,Channel,Anchor"));
  EXPECT_FALSE(
      looks_like_capture_line("1742248940709,6C1DEBA3FFAC,-57,-5,-20,20,6C1DEBA09949,37107"));
}

}  // namespace
}  // namespace ips::ble_aoa
