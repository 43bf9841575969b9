// Records out of TCP reads, files and UDP datagrams (drivers/uwb_tdoa_anchors/record_splitter.hpp).
#include "drivers/uwb_tdoa_anchors/record_splitter.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace ips::uwb_tdoa_anchors {
namespace {

constexpr const char* kSync = "|0001|E|0001|aa|034|136|3b|3e|87|fe|b5|57.63|";
constexpr const char* kBlink =
    "|0006|A|1007|bb|000|084|60|75|7d|3f|e2|67.80|218|2301|12|3084|2470|218|237|744.3593|";

struct Collect {
  std::vector<std::string> records;
  void operator()(std::string_view r) { records.emplace_back(r); }
};

TEST(RecordSplitter, RecordSplitAcrossEveryPossibleTcpReadComesOutWhole) {
  const std::string stream = std::string(kSync) + "\r\n" + kBlink + "\n";
  for (size_t cut = 0; cut <= stream.size(); ++cut) {
    RecordSplitter s;
    Collect c;
    s.feed(std::string_view(stream).substr(0, cut), c);
    s.feed(std::string_view(stream).substr(cut), c);
    ASSERT_EQ(c.records.size(), 2u) << cut;
    EXPECT_EQ(c.records[0], kSync);
    EXPECT_EQ(c.records[1], kBlink);
    EXPECT_FALSE(s.partial());
  }
}

TEST(RecordSplitter, ByteByByteStream) {
  const std::string stream = std::string(kBlink) + "\n" + kSync + "\n";
  RecordSplitter s;
  Collect c;
  for (char ch : stream) s.feed(std::string_view(&ch, 1), c);
  ASSERT_EQ(c.records.size(), 2u);
  EXPECT_EQ(c.records[1], kSync);
}

TEST(RecordSplitter, RecordsWithoutNewlineAreSeparatedWhereTheNextStarts) {
  RecordSplitter s;
  Collect c;
  s.feed(std::string(kSync) + kBlink + kSync, c);
  ASSERT_EQ(c.records.size(), 2u);
  EXPECT_EQ(c.records[0], kSync);
  EXPECT_EQ(c.records[1], kBlink);
  EXPECT_TRUE(s.partial());  // the last one may go on
  EXPECT_TRUE(s.finish(c));
  ASSERT_EQ(c.records.size(), 3u);
  EXPECT_EQ(c.records[2], kSync);
  EXPECT_FALSE(s.finish(c));
}

TEST(RecordSplitter, SeveralRecordsPerDatagramAndNothingCarriedOver) {
  RecordSplitter s;
  Collect c;
  s.feed_datagram(std::string(kSync) + "\n" + kBlink + "\n" + kSync, c);  // no final newline
  ASSERT_EQ(c.records.size(), 3u);
  s.feed_datagram("|0001|E|0001|aa|034", c);  // a datagram cut short stays one bad record
  s.feed_datagram(std::string(kBlink), c);
  ASSERT_EQ(c.records.size(), 5u);
  EXPECT_EQ(c.records[3], "|0001|E|0001|aa|034");
  EXPECT_EQ(c.records[4], kBlink);
}

TEST(RecordSplitter, OverlongRecordsAreSkippedAndCounted) {
  RecordSplitter s;
  Collect c;
  s.feed(std::string(1000, 'x') + "\n" + kSync + "\n" + std::string(300, '7'), c);
  EXPECT_EQ(s.overlong_records(), 2);
  s.feed(std::string(5000, '7') + "|" + kSync + "\n", c);  // "||" ends the overlong one too
  EXPECT_EQ(s.overlong_records(), 2);                      // still the same overlong record
  ASSERT_EQ(c.records.size(), 2u);
  EXPECT_EQ(c.records[0], kSync);
  EXPECT_EQ(c.records[1], kSync);
  // Exactly kMaxRecordBytes is kept.
  std::string max(kMaxRecordBytes, 'a');
  s.feed(max + "\n", c);
  ASSERT_EQ(c.records.size(), 3u);
  EXPECT_EQ(c.records[2].size(), kMaxRecordBytes);
  EXPECT_EQ(s.overlong_records(), 2);
}

TEST(RecordSplitter, ResetForgetsAPartialRecord) {
  RecordSplitter s;
  Collect c;
  s.feed("|0006|A|1007|bb|00", c);
  s.reset();
  s.feed(std::string(kSync) + "\n", c);
  ASSERT_EQ(c.records.size(), 1u);
  EXPECT_EQ(c.records[0], kSync);
}

TEST(RecordSplitter, BlankLinesAreNotRecords) {
  RecordSplitter s;
  Collect c;
  s.feed("\n\r\n\n", c);
  EXPECT_TRUE(c.records.empty());
}

}  // namespace
}  // namespace ips::uwb_tdoa_anchors
