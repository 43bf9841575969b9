// can-utils candump text (drivers/uwb_can/candump_parser.hpp): lines as candump writes them
// (`candump -L`, the screen format, CAN FD, extended ids, remote and error frames, DROPCOUNT),
// the formatter's output read back, and bad lines, each refused with its reason. The examples are
// those of can-utils' lib.h (parse_canframe, sprint_long_canframe) and candump's log format.
#include "drivers/uwb_can/candump_parser.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace ips::uwb_can {
namespace {

std::vector<uint8_t> payload(const CanFrame& f) {
  return std::vector<uint8_t>(f.data.begin(), f.data.begin() + f.len);
}

CandumpLine frame_line(const std::string& text) {
  CandumpLine l = parse_candump_line(text);
  EXPECT_EQ(l.kind, CandumpLineKind::kFrame) << text << ": " << l.reason;
  return l;
}

void expect_bad(const std::string& text, const std::string& reason_part) {
  const CandumpLine l = parse_candump_line(text);
  EXPECT_EQ(l.kind, CandumpLineKind::kBad) << text;
  EXPECT_NE(l.reason.find(reason_part), std::string::npos)
      << text << ": reason '" << l.reason << "' lacks '" << reason_part << "'";
}

TEST(CandumpParser, ReadsALogLine) {
  const auto l = frame_line("(1436509052.249713) can0 123#DEADBEEF");
  EXPECT_TRUE(l.has_time);
  EXPECT_EQ(l.utime, 1436509052249713);
  EXPECT_EQ(l.interface, "can0");
  EXPECT_EQ(l.frame.id, 0x123u);
  EXPECT_FALSE(l.frame.extended || l.frame.remote || l.frame.error || l.frame.fd);
  EXPECT_EQ(payload(l.frame), (std::vector<uint8_t>{0xDE, 0xAD, 0xBE, 0xEF}));
}

TEST(CandumpParser, ReadsTheCompactSyntaxOfCanUtils) {
  EXPECT_EQ(frame_line("(1436509052.249713) can0 123#").frame.len, 0);
  const auto ext = frame_line("(1436509052.249713) can1 12345678#112233").frame;
  EXPECT_TRUE(ext.extended);
  EXPECT_EQ(ext.id, 0x12345678u);
  EXPECT_EQ(ext.len, 3);
  const auto low_ext = frame_line("(1436509052.249713) can1 00000123#11").frame;
  EXPECT_TRUE(low_ext.extended) << "8 digits are an extended id even below 0x800";
  EXPECT_EQ(low_ext.id, 0x123u);
  const auto dots = frame_line("(1436509052.249713) can0 123#11.2233.44556677.88").frame;
  EXPECT_EQ(payload(dots), (std::vector<uint8_t>{0x11, 0x22, 0x33, 0x44, 0x55, 0x66, 0x77, 0x88}));
  EXPECT_EQ(frame_line("(1436509052.249713) can0 7a1#aabbccdd").frame.id, 0x7A1u);
  const auto raw_dlc = frame_line("(1436509052.249713) can0 123#1122334455667788_E").frame;
  EXPECT_EQ(raw_dlc.len, 8);
  EXPECT_EQ(raw_dlc.len8_dlc, 14);
}

TEST(CandumpParser, ReadsRemoteFrames) {
  const auto r = frame_line("(1436509052.249713) can0 123#R").frame;
  EXPECT_TRUE(r.remote);
  EXPECT_EQ(r.len, 0);
  EXPECT_EQ(frame_line("(1436509052.249713) can0 123#R7").frame.len, 7);
  EXPECT_TRUE(frame_line("(1436509052.249713) can0 7A1#r").frame.remote);
  const auto ext = frame_line("(1436509052.249713) can0 12345678#R5").frame;
  EXPECT_TRUE(ext.remote && ext.extended);
  EXPECT_EQ(ext.len, 5);
}

TEST(CandumpParser, ReadsCanFdFrames) {
  const auto f = frame_line("(1436509052.249713) can0 123##1112233").frame;
  EXPECT_TRUE(f.fd);
  EXPECT_EQ(f.fd_flags, 1);  // BRS
  EXPECT_EQ(payload(f), (std::vector<uint8_t>{0x11, 0x22, 0x33}));
  EXPECT_EQ(frame_line("(1436509052.249713) can0 123##3").frame.len, 0);
  const std::string bytes64(128, 'A');
  const auto big = frame_line("(1436509052.249713) can0 12345678##0" + bytes64).frame;
  EXPECT_EQ(big.len, 64);
  EXPECT_TRUE(big.extended && big.fd);
  EXPECT_EQ(big.data[63], 0xAA);
  expect_bad("(1436509052.249713) can0 123##0" + std::string(20, 'A'), "not a CAN FD length");
  expect_bad("(1436509052.249713) can0 123##0" + bytes64 + "AA", "more than 64 data bytes");
  expect_bad("(1436509052.249713) can0 123##", "without a flags digit");
  expect_bad("(1436509052.249713) can0 123###1122", "CAN XL");
}

TEST(CandumpParser, ReadsErrorFrames) {
  // 8 digits with CAN_ERR_FLAG (0x20000000): an error frame, class bits in the id.
  const auto e = frame_line("(1436509052.249713) can0 20000004#0001000000000000").frame;
  EXPECT_TRUE(e.error);
  EXPECT_FALSE(e.extended);
  EXPECT_EQ(e.id, 0x4u);  // CAN_ERR_CRTL
  EXPECT_EQ(describe_error_frame(e), "controller-problem (rx-overflow)");
  EXPECT_TRUE(error_frame_lost_frames(e));
  const auto busoff = frame_line("(1436509052.249713) can0 20000040#0000000000000000").frame;
  EXPECT_EQ(describe_error_frame(busoff), "bus-off");
  EXPECT_FALSE(error_frame_lost_frames(busoff));
  expect_bad("(1436509052.249713) can0 20000040#R", "error frame cannot be a remote request");
  expect_bad("(1436509052.249713) can0 20000040##0", "error frame cannot be CAN FD");
  expect_bad("(1436509052.249713) can0 C0000123#00", "bits above bit 29");
}

TEST(CandumpParser, ReadsTheDirectionFlagOfCandumpX) {
  EXPECT_EQ(frame_line("(1436509052.249713) can0 123#00 R").frame.len, 1);
  EXPECT_EQ(frame_line("(1436509052.249713) can0 123#00 T").frame.len, 1);
  expect_bad("(1436509052.249713) can0 123#00 X", "unexpected 'X'");
  expect_bad("(1436509052.249713) can0 123#00 R R", "unexpected 'R'");
}

TEST(CandumpParser, ReadsTheScreenFormat) {
  const auto a = frame_line("  can0  123   [8]  DE AD BE EF 00 11 22 33");
  EXPECT_FALSE(a.has_time);
  EXPECT_EQ(a.interface, "can0");
  EXPECT_EQ(a.frame.id, 0x123u);
  EXPECT_EQ(payload(a.frame),
            (std::vector<uint8_t>{0xDE, 0xAD, 0xBE, 0xEF, 0x00, 0x11, 0x22, 0x33}));
  const auto t = frame_line(" (1436509052.249713)  can0  123   [3]  11 22 33");
  EXPECT_TRUE(t.has_time);
  EXPECT_EQ(t.utime, 1436509052249713);
  const auto ext = frame_line("  can0  12345678   [3]  11 22 33").frame;
  EXPECT_TRUE(ext.extended);
  const auto rtr = frame_line("  can0  12345678   [0]  remote request").frame;
  EXPECT_TRUE(rtr.remote && rtr.extended);
  const auto fd = frame_line("  can0  12345678  [12]  00 11 22 33 44 55 66 77 88 99 AA BB").frame;
  EXPECT_TRUE(fd.fd);
  EXPECT_EQ(fd.len, 12);
  const auto err = frame_line("  can0  20001111   [7]  C6 23 7B 32 69 98 3C      ERRORFRAME").frame;
  EXPECT_TRUE(err.error);
  EXPECT_EQ(err.id, 0x1111u);
  const auto ascii = frame_line("  can0  14B   [8]  4A 94 E8 2A EC 58 55 62   'J..*.XUb'").frame;
  EXPECT_EQ(ascii.len, 8);
  const auto x = frame_line(" (1436509052.249713)  can0  RX - -  123   [2]  01 02").frame;
  EXPECT_EQ(x.len, 2);
  // Relative timestamps (-t d, -t z) and the local date of -t A carry no absolute time.
  EXPECT_FALSE(frame_line(" (000.000123)  can0  123   [1]  01").has_time);
  EXPECT_FALSE(frame_line(" (2015-07-10 08:17:32.249713)  can0  123   [1]  01").has_time);
}

TEST(CandumpParser, RefusesScreenLinesWhoseLengthDoesNotMatch) {
  expect_bad("  can0  123   [8]  DE AD BE EF 00 11 22", "DLC mismatch: length 8 but 7 data bytes");
  expect_bad("  can0  123   [2]  DE AD BE", "unexpected 'BE' after 2 data bytes");
  expect_bad("  can0  123   [9]  DE AD BE EF 00 11 22 33 44", "not a CAN length");
  expect_bad("  can0  123   [x]  DE", "is not [N] or [NN]");
  expect_bad("  can0  123   [13]  DE", "not a CAN FD length");
  expect_bad("  can0  123   [2]  DE A", "not two hex digits");
  expect_bad("  can0  123   [2]  DE ZZ", "not two hex digits");
  expect_bad("  can0  123", "no [length]");
  expect_bad("  can0  123   [1]  01 ERRORFRAME", "unexpected 'ERRORFRAME'");
  expect_bad("  can0  FFF   [1]  01", "above 7FF");
}

TEST(CandumpParser, TellsBlankNoteAndDropCountLines) {
  EXPECT_EQ(parse_candump_line("").kind, CandumpLineKind::kEmpty);
  EXPECT_EQ(parse_candump_line("   \t ").kind, CandumpLineKind::kEmpty);
  EXPECT_EQ(parse_candump_line("\tcontroller-problem{rx-overflow}").kind, CandumpLineKind::kNote);
  const auto d =
      parse_candump_line("DROPCOUNT: dropped 3 CAN frames on 'can0' socket (total drops 7)");
  EXPECT_EQ(d.kind, CandumpLineKind::kDropCount);
  EXPECT_EQ(d.dropped, 3u);
  expect_bad("DROPCOUNT: dropped many CAN frames", "DROPCOUNT line without a count");
  EXPECT_EQ(frame_line("(1436509052.249713) can0 123#00\r").frame.len, 1);
}

TEST(CandumpParser, RefusesBadLinesWithAReason) {
  expect_bad("(1436509052.249713) can0 123#DEADBEE", "odd number of hex digits");
  expect_bad("(1436509052.249713) can0 123#DEADBEEG", "not hex");
  expect_bad("(1436509052.249713) can0 12#00", "3 (standard) or 8 (extended)");
  expect_bad("(1436509052.249713) can0 1234#00", "3 (standard) or 8 (extended)");
  expect_bad("(1436509052.249713) can0 12G#00", "is not hex");
  expect_bad("(1436509052.249713) can0 800#00", "above 7FF");
  expect_bad("(1436509052.249713) can0 123#001122334455667788", "more than 8 data bytes");
  expect_bad("(1436509052.249713) can0 123#11223344_E", "raw DLC");
  expect_bad("(1436509052.249713) can0 123#1122334455667788_7", "raw DLC");
  expect_bad("(1436509052.249713) can0 123#00.", "ends with '.'");
  expect_bad("(1436509052.249713) can0 123#R9", "unexpected '9'");
  expect_bad("(1436509052.249713) can0", "no frame after the interface");
  expect_bad("(1436509052.249713)", "no interface");
  expect_bad("(1436509052.249713) 123#00", "no interface name");
  expect_bad("(1436509052.249713 can0 123#00", "no closing ')'");
  expect_bad("(1436509052) can0 123#00", "not seconds.fraction");
  expect_bad("(nan) can0 123#00", "not seconds.fraction");
  expect_bad("(NaN.000000) can0 123#00", "not seconds.fraction");
  expect_bad("(-1436509052.249713) can0 123#00", "not seconds.fraction");
  expect_bad("(inf.0) can0 123#00", "not seconds.fraction");
  expect_bad("(1436509052.2497131234) can0 123#00", "more than 9 digits");
  expect_bad("(99999999999999999999.000000) can0 123#00", "out of range");
  expect_bad("(4000000000000.000000) can0 123#00", "out of range");
  expect_bad("(0000000000.000000) can0 123#00", "out of range");
  expect_bad("(" + std::string(400, '9') + ".0) can0 123#00", "out of range");
  expect_bad("(1436509052.249713) averyveryverylongname0 123#00", "interface name");
  expect_bad("garbage", "no frame after the interface");
  expect_bad(std::string(2000, 'x'), "longer than 1024");
  expect_bad(std::string("(1436509052.249713) can\x01 123#00"), "interface name");
}

TEST(CandumpParser, KeepsLargeButPlausibleTimesExactly) {
  // 2096-01-01, below the 4e18 us that core/time.hpp calls plausible: microseconds exactly.
  const auto l = frame_line("(3976214400.999999) can0 123#00");
  EXPECT_EQ(l.utime, 3976214400999999);
  EXPECT_EQ(frame_line("(1436509052.2) can0 123#00").utime, 1436509052200000);
  EXPECT_EQ(frame_line("(1436509052.123456789) can0 123#00").utime, 1436509052123456);
}

TEST(CandumpParser, FormatsLinesItReadsBack) {
  CanFrame f;
  f.id = 0x303;
  f.len = 8;
  const std::vector<uint8_t> bytes{0x01, 0x00, 0xDE, 0x27, 0x00, 0x00, 0x57, 0xC8};
  std::copy(bytes.begin(), bytes.end(), f.data.begin());
  EXPECT_EQ(format_candump_line(f, 1767225600051000, "can0"),
            "(1767225600.051000) can0 303#0100DE27000057C8");
  f.fd = true;
  f.fd_flags = 1;
  EXPECT_EQ(format_candump_line(f, 1767225600051000, "can0"),
            "(1767225600.051000) can0 303##10100DE27000057C8");
  CanFrame remote8;
  remote8.remote = true;
  remote8.id = 0x302;
  remote8.len = 8;
  remote8.len8_dlc = 14;
  // A remote request keeps its raw DLC (fuzz_candump_line found it dropped).
  EXPECT_EQ(format_candump_line(remote8, 1767225600051000, "can0"),
            "(1767225600.051000) can0 302#R8_E");
  CanFrame others[6];
  others[0].extended = true;
  others[0].id = 0x1ABCDEF0;
  others[0].len = 2;
  others[1].remote = true;
  others[1].id = 0x7FF;
  others[1].len = 3;
  others[2].error = true;
  others[2].id = 0x40;
  others[2].len = 8;
  others[3].id = 0x12;
  others[3].len = 8;
  others[3].len8_dlc = 9;
  others[4] = f;
  others[4].len = 64;
  others[5] = remote8;
  for (const CanFrame& o : others) {
    const std::string text = format_candump_line(o, 1436509052249713, "vcan0");
    const auto l = frame_line(text);
    EXPECT_EQ(l.utime, 1436509052249713) << text;
    EXPECT_EQ(l.interface, "vcan0");
    EXPECT_EQ(l.frame.id, o.id) << text;
    EXPECT_EQ(l.frame.extended, o.extended) << text;
    EXPECT_EQ(l.frame.remote, o.remote) << text;
    EXPECT_EQ(l.frame.error, o.error) << text;
    EXPECT_EQ(l.frame.fd, o.fd) << text;
    EXPECT_EQ(l.frame.len, o.len) << text;
    EXPECT_EQ(l.frame.len8_dlc, o.len8_dlc) << text;
    EXPECT_EQ(payload(l.frame), payload(o)) << text;
  }
}

}  // namespace
}  // namespace ips::uwb_can
