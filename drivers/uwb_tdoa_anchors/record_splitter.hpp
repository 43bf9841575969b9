#pragma once
// Bytes from a TCP stream, a file or one UDP datagram into anchor report records
// (anchor_report_parser.hpp). A record ends at LF or CR, and also where the next one starts right
// after it: "|...||...|" is two records, since no record has an empty field, so a sender that
// does not end its records with a newline is still understood (the last such record is complete
// only when the next one starts, or at the end of a datagram or file, or a disconnect). A record
// longer than kMaxRecordBytes is skipped to its end and counted. Pure: no I/O.
#include <cstdint>
#include <string>
#include <string_view>

#include "drivers/uwb_tdoa_anchors/anchor_report_parser.hpp"

namespace ips::uwb_tdoa_anchors {

class RecordSplitter {
 public:
  // Appends stream bytes; calls on_record(std::string_view) for every record they complete.
  template <class OnRecord>
  void feed(std::string_view bytes, OnRecord&& on_record) {
    for (char c : bytes) {
      if (c == '\n' || c == '\r') {
        end_record(on_record);
        continue;
      }
      if (c == '|' && last_ == '|') {
        // "||": the record so far ends at its closing '|'; this '|' opens the next.
        end_record(on_record);
      }
      last_ = c;
      if (overlong_) continue;
      if (record_.size() >= kMaxRecordBytes) {
        ++overlong_records_;
        overlong_ = true;
        record_.clear();
        continue;
      }
      record_ += c;
    }
  }

  // The end of the input (end of file, end of a datagram, a disconnect): the unterminated rest
  // is a record too. Returns true when there was one.
  template <class OnRecord>
  bool finish(OnRecord&& on_record) {
    const bool had = !record_.empty() && !overlong_;
    end_record(on_record);
    return had;
  }

  // Whether an unterminated record is pending.
  bool partial() const { return !record_.empty() || overlong_; }
  // Forgets a pending record (a new connection: its start belonged to the old one).
  void reset() {
    record_.clear();
    overlong_ = false;
    last_ = '\0';
  }
  int64_t overlong_records() const { return overlong_records_; }

  // One whole datagram (or any self-contained buffer): its records, the last one ending at the
  // end of the buffer. Nothing is carried over to the next call.
  template <class OnRecord>
  void feed_datagram(std::string_view bytes, OnRecord&& on_record) {
    reset();
    feed(bytes, on_record);
    finish(on_record);
  }

 private:
  template <class OnRecord>
  void end_record(OnRecord& on_record) {
    if (!overlong_ && !record_.empty()) on_record(std::string_view(record_));
    record_.clear();
    overlong_ = false;
    last_ = '\0';
  }

  std::string record_;
  bool overlong_ = false;
  char last_ = '\0';
  int64_t overlong_records_ = 0;
};

}  // namespace ips::uwb_tdoa_anchors
