// Capture lines of the source experiments (../shared/reference/000_ble_aoa.md section 2,
// "UUDF-time": `2023-12-12 9:50:26.643,COM8,+UUDF:...`), their times in a zone, and the replay
// decoder (drivers/ble_aoa/capture_line.hpp, capture_decoder.hpp).
#include "drivers/ble_aoa/capture_line.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "drivers/ble_aoa/capture_decoder.hpp"

namespace ips::ble_aoa {
namespace {

constexpr const char* kSourceLine =
    "2023-12-12 9:50:26.643,COM8,+UUDF:6C1DEBA5F60C,-68,-30,42,0,37,\"6C1DEBA09862\",\"\",1606101,"
    "25";
// 2023-12-12T09:50:26.643Z; `date -u -d 2023-12-12T09:50:26Z +%s` = 1702374626.
constexpr int64_t kSourceUtcUs = 1702374626643000;

TEST(CaptureLine, ReadsTheSourceForm) {
  const auto r = parse_capture_line(kSourceLine);
  ASSERT_TRUE(r.ok) << r.reason;
  const CivilTime& t = r.line.pc_time;
  EXPECT_EQ(t.year, 2023);
  EXPECT_EQ(t.month, 12);
  EXPECT_EQ(t.day, 12);
  EXPECT_EQ(t.hour, 9);
  EXPECT_EQ(t.minute, 50);
  EXPECT_EQ(t.second, 26);
  EXPECT_EQ(t.micros, 643000);
  EXPECT_EQ(r.line.port, "COM8");
  EXPECT_EQ(r.line.payload, "+UUDF:6C1DEBA5F60C,-68,-30,42,0,37,\"6C1DEBA09862\",\"\",1606101,25");
  EXPECT_EQ(utime_from_civil(t, 0), kSourceUtcUs);
  EXPECT_EQ(utime_from_civil(t, 3600), kSourceUtcUs - 3'600'000'000);  // CET
}

TEST(CaptureLine, ReadsPaddedHoursFractionsAndAByteOrderMark) {
  const auto r = parse_capture_line(
      "\xEF\xBB\xBF"
      "2024-02-29 23:59:59.5,/dev/ttyACM0,OK");
  ASSERT_TRUE(r.ok) << r.reason;
  EXPECT_EQ(r.line.pc_time.micros, 500000);
  EXPECT_EQ(r.line.port, "/dev/ttyACM0");
  EXPECT_EQ(r.line.payload, "OK");
  // 2024-02-29T23:59:59Z = 1709251199 s.
  EXPECT_EQ(utime_from_civil(r.line.pc_time, 0), 1709251199500000);
  const auto whole = parse_capture_line("2023-01-01 00:00:00,COM3,OK");
  ASSERT_TRUE(whole.ok) << whole.reason;
  EXPECT_EQ(utime_from_civil(whole.line.pc_time, 0), 1672531200000000);
}

TEST(CaptureLine, RejectsEveryKindOfBadLineWithItsReason) {
  const std::pair<const char*, const char*> cases[] = {
      {"garbage", "capture: not 'date time,port,line': 'garbage'"},
      {"2023-12-12,COM8,+UUDF:", "capture: time '2023-12-12' is not YYYY-MM-DD H:MM:SS.fff"},
      {"23-12-12 9:50:26.643,COM8,x", "capture: time '23-12-12 9:50:26.643' is not"},
      {"2023-12-12 9:5:26.643,COM8,x", "is not YYYY-MM-DD H:MM:SS.fff"},
      {"2023-12-12 9:50:26.,COM8,x", "is not YYYY-MM-DD H:MM:SS.fff"},
      {"2023-12-12 9:50:26.1234567,COM8,x", "is not YYYY-MM-DD H:MM:SS.fff"},
      {"2023-02-29 9:50:26.643,COM8,x", "capture: no such date or time '2023-02-29 9:50:26.643'"},
      {"2023-13-01 9:50:26.643,COM8,x", "capture: no such date or time"},
      {"2023-12-12 24:00:00.000,COM8,x", "capture: no such date or time"},
      {"2023-12-12 9:50:26.643,COM8", "capture: no port field"},
      {"2023-12-12 9:50:26.643,,+UUDF:", "capture: port '' is not 1 to 32 of A-Za-z0-9_.:/-"},
      {"2023-12-12 9:50:26.643,COM 8,+UUDF:", "capture: port 'COM 8'"},
      {"2023-12-12 9:50:26.643,COM8,", "capture: nothing after the port"},
  };
  for (const auto& [line, reason] : cases) {
    const auto r = parse_capture_line(line);
    EXPECT_FALSE(r.ok) << line;
    EXPECT_NE(r.reason.find(reason), std::string::npos)
        << line << "\n  reason: " << r.reason << "\n  wanted: " << reason;
  }
}

TEST(CaptureLine, ReadsUtcOffsets) {
  EXPECT_EQ(parse_utc_offset("UTC"), 0);
  EXPECT_EQ(parse_utc_offset("Z"), 0);
  EXPECT_EQ(parse_utc_offset("+01:00"), 3600);
  EXPECT_EQ(parse_utc_offset("-05:30"), -19800);
  EXPECT_EQ(parse_utc_offset("+0200"), 7200);
  EXPECT_EQ(parse_utc_offset("+02"), 7200);
  for (const char* bad : {"", "Europe/Prague", "+1", "+15:00", "+01:60", "01:00", "+01:0"})
    EXPECT_FALSE(parse_utc_offset(bad).has_value()) << bad;
  CivilTime before_epoch;
  before_epoch.year = 1969;
  EXPECT_FALSE(utime_from_civil(before_epoch, 0).has_value());
}

TEST(CaptureDecoder, ReplaysEachPortAsItsOwnDeviceWithTheCaptureTime) {
  std::vector<ble_aoa_t> out;
  EventDecoderConfig base;
  base.anchor_names = {{"6C1DEBA09862", "A1"}};
  CaptureDecoder d(
      "ips-ble-aoa", base, [](const CivilTime& t) { return utime_from_civil(t, 3600); },
      [&](const ble_aoa_t& m) { out.push_back(m); });
  EXPECT_EQ(d.decode(kSourceLine).kind, LineOutcome::Kind::kPublished);
  EXPECT_EQ(d.decode(kSourceLine).kind, LineOutcome::Kind::kDuplicate);  // same counter
  // The same event on another port is that port's first: not a duplicate.
  const std::string other =
      "2023-12-12 9:50:26.650,COM9,+UUDF:6C1DEBA5F60C,-68,-30,42,0,37,"
      "\"6C1DEBA09862\",\"\",1606101,25";
  EXPECT_EQ(d.decode(other).kind, LineOutcome::Kind::kPublished);
  EXPECT_EQ(d.decode("2023-12-12 9:50:26.651,COM9,OK").kind, LineOutcome::Kind::kAtLine);
  const auto bad = d.decode("2023-12-12 9:50:26.652,COM9,+UUDF:6C1D");
  EXPECT_EQ(bad.kind, LineOutcome::Kind::kError);
  EXPECT_EQ(bad.reason, "+UUDF: 1 fields, expected 9 or 10");
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].utime, kSourceUtcUs - 3'600'000'000);
  EXPECT_EQ(out[0].source, "ips-ble-aoa:COM8");
  EXPECT_EQ(out[0].anchor_id, "A1");
  EXPECT_EQ(out[0].seq, 25);
  EXPECT_EQ(out[1].utime, kSourceUtcUs - 3'600'000'000 + 7000);
  EXPECT_EQ(out[1].source, "ips-ble-aoa:COM9");
  EXPECT_EQ(d.lines(), 5);
}

TEST(CaptureDecoder, SaysWhenTheZoneHasNoSuchTime) {
  CaptureDecoder d(
      "ips-ble-aoa", {}, [](const CivilTime&) { return std::optional<int64_t>(); }, nullptr);
  const auto r = d.decode(kSourceLine);
  EXPECT_EQ(r.kind, LineOutcome::Kind::kError);
  EXPECT_EQ(r.reason,
            "capture: time '2023-12-12 9:50:26.643' does not exist in the time zone (or is "
            "before 1970)");
}

}  // namespace
}  // namespace ips::ble_aoa
