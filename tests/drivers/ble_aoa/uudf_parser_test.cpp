// The +UUDF parser (drivers/ble_aoa/uudf_parser.hpp) on the formats of the sources: the event of
// ../shared/reference/000_ble_aoa.md section 2 (ten fields), the nine-field form of the u-blox
// XPLR-AOA user guide appendix A.4, the lines of the AT conversation, and every reason.
#include "drivers/ble_aoa/uudf_parser.hpp"

#include <gtest/gtest.h>

#include <string>

namespace ips::ble_aoa {
namespace {

using Kind = UudfParseResult::Kind;

TEST(UudfParser, ReadsTheTenFieldEventOfTheSource) {
  const auto r =
      parse_uudf_line(R"(+UUDF:6C1DEBA5F60C,-68,-30,42,0,37,"6C1DEBA09862","",1606101,25)");
  ASSERT_EQ(r.kind, Kind::kEvent) << r.reason;
  EXPECT_EQ(r.event.tag_id, "6C1DEBA5F60C");
  EXPECT_EQ(r.event.rssi_dbm, -68);
  EXPECT_EQ(r.event.azimuth_raw_deg, -30);
  EXPECT_EQ(r.event.elevation_raw_deg, 42);
  EXPECT_EQ(r.event.reserved, 0);
  EXPECT_EQ(r.event.channel, 37);
  EXPECT_EQ(r.event.anchor_id, "6C1DEBA09862");
  EXPECT_EQ(r.event.user_string, "");
  EXPECT_EQ(r.event.uptime_ms, 1606101);
  EXPECT_TRUE(r.event.has_counter);
  EXPECT_EQ(r.event.counter, 25);
}

TEST(UudfParser, ReadsTheNineFieldFormOfOlderFirmware) {
  // User guide appendix A.4: no counter; field 5 is the second polarisation's RSSI.
  const auto r = parse_uudf_line(R"(+UUDF:CCF9578E0D8A,-42,20,0,-43,38,"CCF9578E0D89","",15869)");
  ASSERT_EQ(r.kind, Kind::kEvent) << r.reason;
  EXPECT_EQ(r.event.reserved, -43);
  EXPECT_EQ(r.event.channel, 38);
  EXPECT_EQ(r.event.uptime_ms, 15869);
  EXPECT_FALSE(r.event.has_counter);
  EXPECT_EQ(r.event.counter, -1);
}

TEST(UudfParser, KeepsTheLegacyRangeRawForTheDecoder) {
  const auto r = parse_uudf_line(R"(+UUDF:6C1DEBA5F60C,-70,150,95,0,39,"6C1DEBA09862","",1606201)");
  ASSERT_EQ(r.kind, Kind::kEvent) << r.reason;
  EXPECT_EQ(r.event.azimuth_raw_deg, 150);
  EXPECT_EQ(r.event.elevation_raw_deg, 95);
}

TEST(UudfParser, KeepsAUserStringWithCommasAndRawBytes) {
  const auto r =
      parse_uudf_line("+UUDF:6C1DEBA5F60C,-68,-30,42,0,37,\"A1\",\"50.1,14.4 \x1b[2J\",1606101,25");
  ASSERT_EQ(r.kind, Kind::kEvent) << r.reason;
  EXPECT_EQ(r.event.user_string, "50.1,14.4 \x1b[2J");
  EXPECT_EQ(r.event.anchor_id, "A1");
}

TEST(UudfParser, ToleratesSpacesAroundFieldsAndDecimals) {
  const auto r = parse_uudf_line(R"(+UUDF:6C1DEBA5F60C, -68 ,-30.5,42,0,37,"A1" ,"",1606101 )");
  ASSERT_EQ(r.kind, Kind::kEvent) << r.reason;
  EXPECT_EQ(r.event.rssi_dbm, -68);
  EXPECT_EQ(r.event.azimuth_raw_deg, -30.5);
}

TEST(UudfParser, ClassifiesTheAtConversation) {
  EXPECT_EQ(parse_uudf_line("OK").at, AtLine::kOk);
  EXPECT_EQ(parse_uudf_line("ERROR").at, AtLine::kError);
  EXPECT_EQ(parse_uudf_line("+CME ERROR: 4").at, AtLine::kError);
  EXPECT_EQ(parse_uudf_line("+STARTUP").at, AtLine::kStartup);
  EXPECT_EQ(parse_uudf_line("ATE0").at, AtLine::kEcho);
  EXPECT_EQ(parse_uudf_line("AT+UDFENABLE=1").at, AtLine::kEcho);
  EXPECT_EQ(parse_uudf_line("+UMLA:6C1DEBA09862p").at, AtLine::kResponse);
  EXPECT_EQ(parse_uudf_line("+UDFCFG:1,50").at, AtLine::kResponse);
  for (const char* l : {"OK", "ERROR", "+STARTUP", "ATE0", "+UMLA:6C1DEBA09862p"})
    EXPECT_EQ(parse_uudf_line(l).kind, Kind::kAtLine) << l;
}

struct Bad {
  const char* line;
  const char* reason;
};

TEST(UudfParser, RejectsEveryKindOfBadLineWithItsReason) {
  const Bad cases[] = {
      // Garbled first lines: the tail of an event, bytes of a half-open port.
      {"DEBA5F60C,-68,-30,42,0,37,\"6C1DEBA09862\",\"\",1606101,25",
       "not a +UUDF event or an AT response: 'DEBA5F60C,-68,-30,42,0,3...'"},
      {"\xfe\x01+UUDF:", "not a +UUDF event or an AT response: '??+UUDF:'"},
      {"+uudf lower", "not a +UUDF event or an AT response: '+uudf lower'"},
      {"+UUDF:6C1DEBA5F60C,-68,-30,4", "+UUDF: 4 fields, expected 9 or 10"},
      {"+UUDF:a,1,2,3,4,5,\"x\",\"\",1,2,3", "+UUDF: more than 10 fields"},
      {"+UUDF:6C1DEBA5F60C,-68,-30,42,0,37,\"6C1DEBA09862,\"\",1606101,25",
       "+UUDF: field 7: text after its closing quote"},
      {"+UUDF:6C1DEBA5F60C,-68,-30,42,0,37,\"6C1DEBA09862\",\"abc",
       "+UUDF: field 8: quote not closed"},
      {"+UUDF:6C1DEBA5F60C,-68,-30,42,0,37,6C1DEBA09862,\"\",1606101,25",
       "+UUDF: anchor id is not a quoted string"},
      {"+UUDF:6C1DEBA5F60C,-68,-30,42,0,37,\"6C1DEBA09862\",\"\",\"1606101\",25",
       "+UUDF: uptime is quoted"},
      {"+UUDF:6C1D EBA5,-68,-30,42,0,37,\"A1\",\"\",1606101,25",
       "+UUDF: tag id '6C1D EBA5' is not 1 to 32 of A-Za-z0-9_.:-"},
      {"+UUDF:,-68,-30,42,0,37,\"A1\",\"\",1606101,25", "+UUDF: tag id '' is not 1 to 32"},
      {"+UUDF:6C1DEBA5F60C,x,-30,42,0,37,\"A1\",\"\",1606101,25",
       "+UUDF: RSSI 'x' is not a number in -128..20 dBm"},
      {"+UUDF:6C1DEBA5F60C,-200,-30,42,0,37,\"A1\",\"\",1606101,25", "+UUDF: RSSI '-200'"},
      {"+UUDF:6C1DEBA5F60C,-68,nan,42,0,37,\"A1\",\"\",1606101,25",
       "+UUDF: azimuth 'nan' is not a number in -90..180 deg"},
      {"+UUDF:6C1DEBA5F60C,-68,-91,42,0,37,\"A1\",\"\",1606101,25", "+UUDF: azimuth '-91'"},
      {"+UUDF:6C1DEBA5F60C,-68,-30,181,0,37,\"A1\",\"\",1606101,25", "+UUDF: elevation '181'"},
      {"+UUDF:6C1DEBA5F60C,-68,-30,1e1,0,37,\"A1\",\"\",1606101,25", "+UUDF: elevation '1e1'"},
      {"+UUDF:6C1DEBA5F60C,-68,-30,42,-,37,\"A1\",\"\",1606101,25",
       "+UUDF: reserved field '-' is not a number"},
      {"+UUDF:6C1DEBA5F60C,-68,-30,42,0,40,\"A1\",\"\",1606101,25",
       "+UUDF: channel '40' is not 0..39"},
      {"+UUDF:6C1DEBA5F60C,-68,-30,42,0,37.5,\"A1\",\"\",1606101,25", "+UUDF: channel '37.5'"},
      {"+UUDF:6C1DEBA5F60C,-68,-30,42,0,37,\"\",\"\",1606101,25",
       "+UUDF: anchor id '' is not 1 to 32 of A-Za-z0-9_.:-"},
      {"+UUDF:6C1DEBA5F60C,-68,-30,42,0,37,\"A1\",\"0123456789012345678901234567890123456789"
       "01234567890123456789012345\",1606101,25",
       "+UUDF: user string longer than 64 bytes"},
      {"+UUDF:6C1DEBA5F60C,-68,-30,42,0,37,\"A1\",\"\",-5,25",
       "+UUDF: uptime '-5' is not a count of ms"},
      {"+UUDF:6C1DEBA5F60C,-68,-30,42,0,37,\"A1\",\"\",99999999999999999999999,25",
       "+UUDF: uptime '99999999999999999999999'"},
      {"+UUDF:6C1DEBA5F60C,-68,-30,42,0,37,\"A1\",\"\",1606101,2147483648",
       "+UUDF: counter '2147483648' is not 0..2147483647"},
      {"+UUDF:6C1DEBA5F60C,-68,-30,42,0,37,\"A1\",\"\",1606101,",
       "+UUDF: counter '' is not 0..2147483647"},
  };
  for (const Bad& b : cases) {
    const auto r = parse_uudf_line(b.line);
    EXPECT_EQ(r.kind, Kind::kError) << b.line;
    EXPECT_NE(r.reason.find(b.reason), std::string::npos)
        << b.line << "\n  reason: " << r.reason << "\n  wanted: " << b.reason;
    for (char c : r.reason) EXPECT_TRUE(c >= 0x20 && c < 0x7f) << r.reason;
  }
}

TEST(UudfParser, AcceptsOnlyTheIdAlphabet) {
  EXPECT_TRUE(valid_id("6C1DEBA09862"));
  EXPECT_TRUE(valid_id("A1"));
  EXPECT_TRUE(valid_id("hall.a-1:x_2"));
  EXPECT_FALSE(valid_id(""));
  EXPECT_FALSE(valid_id("A 1"));
  EXPECT_FALSE(valid_id("A\"1"));
  EXPECT_FALSE(valid_id(std::string(33, 'A')));
}

}  // namespace
}  // namespace ips::ble_aoa
