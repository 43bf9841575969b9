// The anchor report parser and encoder on the records of source 004 §1 (Fig. 3.2, OCR-corrected
// in /work/shared/reference/004_uwb_kf.md) and on bad input.
#include "drivers/uwb_tdoa_anchors/anchor_report_parser.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

namespace ips::uwb_tdoa_anchors {
namespace {

// 004 §1, the three examples (the sync's fifth counter byte as the prose gives it, b5).
constexpr const char* kSync = "|0001|E|0001|aa|034|136|3b|3e|87|fe|b5|57.63|";
constexpr const char* kBlink =
    "|0006|A|1007|bb|000|084|60|75|7d|3f|e2|67.80|218|2301|12|3084|2470|218|237|744.3593|";
constexpr const char* kSyncReply =
    "|0006|A|0001|aa|034|136|61|15|93|d9|b5|67.80|184|1888|12|1967|1693|269|240|744.2812|";

// Eight diagnostics, as every 'A' record has them.
const std::string kDiag = "218|2301|12|3084|2470|218|237|744.3593|";

AnchorReport parse_ok(const std::string& text) {
  const AnchorReportParse p = parse_anchor_report(text);
  EXPECT_TRUE(p.ok) << text << ": " << p.reason;
  return p.report;
}

std::string reason_for(const std::string& text) {
  const AnchorReportParse p = parse_anchor_report(text);
  EXPECT_FALSE(p.ok) << text;
  EXPECT_FALSE(p.reason.empty());
  return p.reason;
}

TEST(AnchorReportParser, MasterSyncTransmitRecordOfSource004) {
  const AnchorReport r = parse_ok(kSync);
  EXPECT_EQ(r.anchor_id, "0001");
  EXPECT_EQ(r.sender_id, "0001");
  EXPECT_TRUE(r.transmit);
  EXPECT_TRUE(r.is_sync);
  EXPECT_EQ(r.group, 34);
  EXPECT_EQ(r.seq_in_group, 136);
  EXPECT_EQ(r.seq(), 34136);
  EXPECT_EQ(r.rx_counter, 0x3b3e87feb5);
  // 004 §5: 0x3b3e87feb5 / 63.8976e9 = 3.982187 s.
  EXPECT_NEAR(static_cast<double>(r.rx_counter) / kCounterHz, 3.982187, 5e-7);
  EXPECT_DOUBLE_EQ(r.temperature_c, 57.63);
  EXPECT_EQ(r.diagnostic_count, 0u);
}

TEST(AnchorReportParser, TagBlinkRecordOfSource004) {
  const AnchorReport r = parse_ok(kBlink);
  EXPECT_EQ(r.anchor_id, "0006");
  EXPECT_EQ(r.sender_id, "1007");
  EXPECT_FALSE(r.transmit);
  EXPECT_FALSE(r.is_sync);
  EXPECT_EQ(r.seq(), 84);
  EXPECT_EQ(r.rx_counter, 0x60757d3fe2);
  EXPECT_NEAR(static_cast<double>(r.rx_counter) / kCounterHz, 6.483624, 5e-7);
  EXPECT_DOUBLE_EQ(r.temperature_c, 67.80);
  ASSERT_EQ(r.diagnostic_count, 8u);
  const double expected[8] = {218, 2301, 12, 3084, 2470, 218, 237, 744.3593};
  for (size_t i = 0; i < 8; ++i) EXPECT_DOUBLE_EQ(r.diagnostics[i], expected[i]) << i;
}

TEST(AnchorReportParser, SyncReceptionRecordOfSource004MatchesTheSyncByKey) {
  const AnchorReport reply = parse_ok(kSyncReply);
  const AnchorReport sync = parse_ok(kSync);
  EXPECT_FALSE(reply.transmit);
  EXPECT_TRUE(reply.is_sync);
  EXPECT_EQ(reply.rx_counter, 0x611593d9b5);
  EXPECT_NEAR(static_cast<double>(reply.rx_counter) / kCounterHz, 6.525657, 5e-7);
  // One event's matching key is (sender, group, seq) (004 §1).
  EXPECT_EQ(reply.sender_id, sync.sender_id);
  EXPECT_EQ(reply.seq(), sync.seq());
  EXPECT_DOUBLE_EQ(reply.diagnostics[7], 744.2812);
}

TEST(AnchorReportParser, MapsToUwbRxAsTheSimulatorDoes) {
  const uwb_rx_t m = to_uwb_rx(parse_ok(kSync), 1767225600123456, "src", "0001", "0001");
  EXPECT_EQ(m.utime, 1767225600123456);
  EXPECT_EQ(m.source, "src");
  EXPECT_EQ(m.anchor_id, m.sender_id);  // the master's own record names itself
  EXPECT_TRUE(m.is_sync);
  EXPECT_EQ(m.seq, 34136);
  EXPECT_EQ(m.rx_counter, 0x3b3e87feb5);
  EXPECT_EQ(m.counter_hz, 63.8976e9);
  EXPECT_TRUE(std::isnan(m.rx_power_dbm));
  EXPECT_TRUE(std::isnan(m.fp_power_dbm));
  EXPECT_TRUE(std::isnan(m.quality));
  const uwb_rx_t b = to_uwb_rx(parse_ok(kBlink), 1, "src", "A6", "T7");
  EXPECT_EQ(b.anchor_id, "A6");
  EXPECT_EQ(b.sender_id, "T7");
  EXPECT_FALSE(b.is_sync);
}

TEST(AnchorReportParser, ReceivePowerIsNaNUnlessTheDw1000ReadingIsAskedFor) {
  const AnchorReport blink = parse_ok(kBlink);
  const ReceivePower none = receive_power(blink, PowerModel::kNone);
  EXPECT_TRUE(std::isnan(none.rx_power_dbm) && std::isnan(none.fp_power_dbm));
  // DW1000 user manual §4.7.2 on 004's blink: C = 218, N = 237, F = 2301, 3084, 2470:
  // 10 log10(218 * 2^17 / 237^2) = 27.0647 dB, 10 log10((2301^2 + 3084^2 + 2470^2) / 237^2) =
  // 25.7079 dB, minus A = 121.74 (64 MHz PRF) or 113.77 (16 MHz).
  const ReceivePower p64 = receive_power(blink, PowerModel::kDw1000Prf64);
  EXPECT_NEAR(p64.rx_power_dbm, -94.6753, 1e-3);
  EXPECT_NEAR(p64.fp_power_dbm, -96.0321, 1e-3);
  const ReceivePower p16 = receive_power(blink, PowerModel::kDw1000Prf16);
  EXPECT_NEAR(p16.rx_power_dbm, -86.7053, 1e-3);
  EXPECT_NEAR(p16.fp_power_dbm, -88.0621, 1e-3);
  // 004's sync reception: first path 5.3 dB under the total, as the manual's NLOS hint reads.
  const ReceivePower reply = receive_power(parse_ok(kSyncReply), PowerModel::kDw1000Prf64);
  EXPECT_NEAR(reply.rx_power_dbm, -93.8716, 1e-3);
  EXPECT_NEAR(reply.fp_power_dbm, -99.2159, 1e-3);
  const uwb_rx_t m = to_uwb_rx(blink, 1, "s", "a", "b", PowerModel::kDw1000Prf64);
  EXPECT_FLOAT_EQ(m.rx_power_dbm, p64.rx_power_dbm);
  EXPECT_FLOAT_EQ(m.fp_power_dbm, p64.fp_power_dbm);
  EXPECT_TRUE(std::isnan(m.quality));
  // No diagnostics ('E'), or values with no finite level: NaN, never -inf.
  EXPECT_TRUE(std::isnan(receive_power(parse_ok(kSync), PowerModel::kDw1000Prf64).rx_power_dbm));
  const AnchorReport zeros =
      parse_ok("|0006|A|1007|bb|000|084|60|75|7d|3f|e2|67.80|0|0|0|0|0|0|0|0|");
  const ReceivePower z = receive_power(zeros, PowerModel::kDw1000Prf64);
  EXPECT_TRUE(std::isnan(z.rx_power_dbm) && std::isnan(z.fp_power_dbm));
  const AnchorReport no_cir =
      parse_ok("|0006|A|1007|bb|000|084|60|75|7d|3f|e2|67.80|218|2301|12|3084|2470|0|237|744|");
  EXPECT_TRUE(std::isnan(receive_power(no_cir, PowerModel::kDw1000Prf64).rx_power_dbm));
  EXPECT_NEAR(receive_power(no_cir, PowerModel::kDw1000Prf64).fp_power_dbm, -96.0321, 1e-3);
}

TEST(AnchorReportParser, AcceptsSurroundingBlanksCaseAndShortNumbers) {
  EXPECT_EQ(parse_ok(" \t|00aB|e|00aB|AA|1|2|FF|ff|00|00|01|-3.5|\t ").rx_counter, 0xffff000001);
  EXPECT_EQ(parse_ok("|00aB|e|00aB|AA|1|2|FF|ff|00|00|01|-3.5|").seq(), 1002);
  EXPECT_EQ(parse_ok("|00aB|e|00aB|AA|1|2|FF|ff|00|00|01|-3.5|").anchor_id, "00aB");  // as sent
  EXPECT_EQ(parse_ok("|0002|A|1001|bb|999|999|ff|ff|ff|ff|ff|20|" + kDiag).seq(), 999999);
  EXPECT_EQ(parse_ok("|0002|A|1001|bb|999|999|ff|ff|ff|ff|ff|20|" + kDiag).rx_counter,
            (int64_t{1} << 40) - 1);
}

TEST(AnchorReportParser, RefusesTruncatedRecords) {
  const std::string blink = kBlink;
  // Every proper prefix: no prefix of a record is a record (a reception cut after its
  // temperature has the 12 fields of a transmit record, but it is an 'A' record).
  for (size_t n = 0; n < blink.size(); ++n) {
    const AnchorReportParse p = parse_anchor_report(blink.substr(0, n));
    EXPECT_FALSE(p.ok) << blink.substr(0, n);
  }
  EXPECT_NE(reason_for("|0006|A|1007|bb|000|084|60|75|7d|3f|e2|67.80|218").find("does not end"),
            std::string::npos);
  EXPECT_NE(reason_for("|0006|A|1007|bb|000|084|60|75|7d|").find("fields"), std::string::npos);
}

TEST(AnchorReportParser, RefusesWrongFieldCounts) {
  EXPECT_NE(reason_for("|0006|A|1007|bb|000|084|60|75|7d|3f|e2|67.80|218|2301|").find("4 fields"),
            std::string::npos);
  EXPECT_NE(reason_for("|0006|A|1007|bb|000|084|60|75|7d|3f|e2|").find("11 fields"),
            std::string::npos);
  EXPECT_NE(reason_for(std::string(kBlink) + "1|").find("21 fields"), std::string::npos);
  EXPECT_NE(reason_for("|").find("does not end"), std::string::npos);
  EXPECT_EQ(reason_for("|0006|A|1007|bb|000|084|60|75|7d|3f|e2|67.80|"),
            "'A' (reception) record of 12 fields (expected 20)");
  EXPECT_EQ(reason_for("|0001|E|0001|aa|034|136|3b|3e|87|fe|b5|57.63|" + kDiag),
            "'E' (transmit) record of 20 fields (expected 12)");
}

TEST(AnchorReportParser, RefusesMissingPipes) {
  EXPECT_NE(reason_for("0001|E|0001|aa|034|136|3b|3e|87|fe|b5|57.63|").find("start with '|'"),
            std::string::npos);
  EXPECT_NE(reason_for("|0001|E|0001|aa|034|136|3b|3e|87|fe|b5|57.63").find("end with '|'"),
            std::string::npos);
  // A pipe missing inside: two fields run together.
  EXPECT_NE(reason_for("|0001|E|0001|aa|034136|3b|3e|87|fe|b5|57.63|").find("fields"),
            std::string::npos);
  EXPECT_NE(reason_for("|0001 E 0001 aa 034 136 3b 3e 87 fe b5 57.63|").find("fields"),
            std::string::npos);
}

TEST(AnchorReportParser, RefusesNonHexCounterBytesAndIds) {
  EXPECT_EQ(reason_for("|0006|A|1007|bb|000|084|60|75|7g|3f|e2|67.80|" + kDiag),
            "counter byte 2 '7g' is not 2 hex digits");
  EXPECT_EQ(reason_for("|0006|A|1007|bb|000|084|60|75|7|3f|e2|67.80|" + kDiag),
            "counter byte 2 '7' is not 2 hex digits");
  EXPECT_EQ(reason_for("|0006|A|1007|bb|000|084|60|75|7d3|3f|e2|67.80|" + kDiag),
            "counter byte 2 '7d3' is not 2 hex digits");
  EXPECT_EQ(reason_for("|006|A|1007|bb|000|084|60|75|7d|3f|e2|67.80|" + kDiag),
            "anchor id '006' is not 4 hex digits");
  EXPECT_EQ(reason_for("|0006|A|1O07|bb|000|084|60|75|7d|3f|e2|67.80|" + kDiag),
            "sender id '1O07' is not 4 hex digits");
}

TEST(AnchorReportParser, RefusesUnknownFlagAndKind) {
  EXPECT_EQ(reason_for("|0006|X|1007|bb|000|084|60|75|7d|3f|e2|67.80|"),
            "record flag 'X' is not E (master's transmit) or A (reception)");
  EXPECT_EQ(reason_for("|0006|A|1007|cc|000|084|60|75|7d|3f|e2|67.80|"),
            "message kind 'cc' is not aa (sync) or bb (blink)");
  EXPECT_EQ(reason_for("|0006|AA|1007|bb|000|084|60|75|7d|3f|e2|67.80|"),
            "record flag 'AA' is not E (master's transmit) or A (reception)");
}

TEST(AnchorReportParser, RefusesRecordsUwbRxCannotTellApart) {
  // 'E' is the master's own record: a sync, naming itself.
  EXPECT_NE(reason_for("|0001|E|0002|aa|034|136|3b|3e|87|fe|b5|57.63|").find("another sender"),
            std::string::npos);
  EXPECT_NE(reason_for("|0001|E|0001|bb|034|136|3b|3e|87|fe|b5|57.63|").find("blink"),
            std::string::npos);
  // An 'A' record naming itself would be published like the master's 'E' record.
  EXPECT_NE(
      reason_for("|0001|A|0001|aa|034|136|3b|3e|87|fe|b5|57.63|" + kDiag).find("names itself"),
      std::string::npos);
}

TEST(AnchorReportParser, RefusesBadSequenceNumbers) {
  EXPECT_EQ(reason_for("|0006|A|1007|bb|0000|084|60|75|7d|3f|e2|67.80|" + kDiag),
            "group '0000' is not 1 to 3 decimal digits");
  EXPECT_EQ(reason_for("|0006|A|1007|bb|000|08a|60|75|7d|3f|e2|67.80|" + kDiag),
            "sequence number '08a' is not 1 to 3 decimal digits");
  EXPECT_EQ(reason_for("|0006|A|1007|bb|000|-84|60|75|7d|3f|e2|67.80|" + kDiag),
            "sequence number '-84' is not 1 to 3 decimal digits");
}

TEST(AnchorReportParser, RefusesHugeNanAndMalformedValues) {
  const std::string head = "|0001|E|0001|aa|034|136|3b|3e|87|fe|b5|";
  for (const char* v : {"nan", "NaN", "inf", "-inf", "1e400", "1e5", "1234567890", "0x10", "+5",
                        "5.", ".5", "1.2.3", "1.0000000001", "--1", "-", " 5"}) {
    const AnchorReportParse p = parse_anchor_report(head + v + "|");
    EXPECT_FALSE(p.ok) << v;
    EXPECT_NE(p.reason.find("temperature"), std::string::npos) << v << ": " << p.reason;
  }
  EXPECT_EQ(reason_for("|0006|A|1007|bb|000|084|60|75|7d|3f|e2|67.80|218|2301|12|nan|2470|218|"
                       "237|744.3593|"),
            "diagnostic value 4 'nan' is not a decimal number");
  EXPECT_DOUBLE_EQ(parse_ok(head + "123456789.123456789|").temperature_c, 123456789.123456789);
}

TEST(AnchorReportParser, RefusesEmptyFieldsAndEmptyRecords) {
  EXPECT_EQ(reason_for("|0006|A|1007|bb||084|60|75|7d|3f|e2|67.80|"), "field 5 is empty");
  EXPECT_EQ(reason_for("|0006|A|1007|bb|000|084|60|75|7d|3f|e2||"), "field 12 is empty");
  EXPECT_EQ(reason_for("|||||||||||||"), "field 1 is empty");
  EXPECT_EQ(reason_for(""), "empty record");
  EXPECT_EQ(reason_for("   "), "empty record");
}

TEST(AnchorReportParser, RefusesOverlongRecordsAndEscapesWhatItQuotes) {
  const std::string longer(kMaxRecordBytes + 1, '|');
  EXPECT_NE(reason_for(longer).find("bytes"), std::string::npos);
  const std::string r = reason_for("|0006|\x1b[2J|1007|bb|000|084|60|75|7d|3f|e2|67.80|");
  EXPECT_EQ(r.find('\x1b'), std::string::npos) << r;
  EXPECT_NE(r.find("\\x1b"), std::string::npos) << r;
}

uwb_rx_t rx(const std::string& anchor, const std::string& sender, bool sync, int32_t seq,
            int64_t counter) {
  uwb_rx_t m = to_uwb_rx(AnchorReport{}, 1, "test", anchor, sender);
  m.is_sync = sync;
  m.seq = seq;
  m.rx_counter = counter;
  return m;
}

TEST(AnchorReportEncoder, WritesTheRecordsOfSource004) {
  // The three examples, their diagnostics as 0 (uwb_rx_t carries none).
  AnchorReportEncode e = encode_anchor_report(rx("0001", "0001", true, 34136, 0x3b3e87feb5), 57.63);
  ASSERT_TRUE(e.ok) << e.reason;
  EXPECT_EQ(e.record, kSync);
  e = encode_anchor_report(rx("0006", "1007", false, 84, 0x60757d3fe2), 67.8);
  ASSERT_TRUE(e.ok) << e.reason;
  EXPECT_EQ(e.record, "|0006|A|1007|bb|000|084|60|75|7d|3f|e2|67.80|0|0|0|0|0|0|0|0|");
  e = encode_anchor_report(rx("0006", "0001", true, 34136, 0x611593d9b5), 67.8);
  EXPECT_EQ(e.record, "|0006|A|0001|aa|034|136|61|15|93|d9|b5|67.80|0|0|0|0|0|0|0|0|");
}

TEST(AnchorReportEncoder, RoundTripsThroughTheParser) {
  for (const uwb_rx_t& m : {rx("0004", "0004", true, 0, 0), rx("0001", "0004", true, 7, 12345),
                            rx("0003", "1001", false, 999999, (int64_t{1} << 40) - 1),
                            rx("ABCD", "1fff", false, 123456, 0x0102030405)}) {
    const AnchorReportEncode e = encode_anchor_report(m);
    ASSERT_TRUE(e.ok) << e.reason;
    const AnchorReportParse p = parse_anchor_report(e.record);
    ASSERT_TRUE(p.ok) << e.record << ": " << p.reason;
    const uwb_rx_t back =
        to_uwb_rx(p.report, m.utime, m.source, p.report.anchor_id, p.report.sender_id);
    EXPECT_EQ(back.anchor_id, m.anchor_id);
    EXPECT_EQ(back.sender_id, m.sender_id);
    EXPECT_EQ(back.is_sync, m.is_sync);
    EXPECT_EQ(back.seq, m.seq);
    EXPECT_EQ(back.rx_counter, m.rx_counter);
  }
}

TEST(AnchorReportEncoder, WrapsSeqAtTheWiresMillion) {
  const AnchorReportEncode e = encode_anchor_report(rx("0001", "1001", false, 1234567, 1));
  ASSERT_TRUE(e.ok);
  EXPECT_EQ(e.record, "|0001|A|1001|bb|234|567|00|00|00|00|01|25.00|0|0|0|0|0|0|0|0|");
}

TEST(AnchorReportEncoder, RefusesWhatTheWireCannotCarry) {
  EXPECT_NE(encode_anchor_report(rx("A1", "1001", false, 1, 1)).reason.find("anchor id 'A1'"),
            std::string::npos);
  EXPECT_NE(encode_anchor_report(rx("0001", "T1", false, 1, 1)).reason.find("sender id 'T1'"),
            std::string::npos);
  EXPECT_FALSE(encode_anchor_report(rx("0001", "0001", false, 1, 1)).ok);
  EXPECT_FALSE(encode_anchor_report(rx("0001", "1001", false, -1, 1)).ok);
  EXPECT_FALSE(encode_anchor_report(rx("0001", "1001", false, 1, int64_t{1} << 40)).ok);
  EXPECT_FALSE(encode_anchor_report(rx("0001", "1001", false, 1, -1)).ok);
  uwb_rx_t other_clock = rx("0001", "1001", false, 1, 1);
  other_clock.counter_hz = 1e9;
  EXPECT_NE(encode_anchor_report(other_clock).reason.find("counter_hz"), std::string::npos);
  EXPECT_FALSE(encode_anchor_report(rx("0001", "1001", false, 1, 1), std::nan("")).ok);
  EXPECT_FALSE(encode_anchor_report(rx("0001", "1001", false, 1, 1), 1e300).ok);
}

}  // namespace
}  // namespace ips::uwb_tdoa_anchors
