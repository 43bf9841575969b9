// libFuzzer target: the delimited-text reader every file input shares (core/table_text.hpp) on
// arbitrary bytes: lines through the reader, columns mapped from whatever header it found, every
// field through the number, time and unit parsers, and the import verdict. Nothing may crash,
// hang or leak, and every text it returns for a message must be printable ASCII.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>
#include <vector>

#include "core/table_text.hpp"

namespace {

bool printable(std::string_view s) {
  for (char c : s)
    if (c < 0x20 || c > 0x7e) return false;
  return true;
}

const std::vector<ips::table::KnownColumn> kKnown = {
    {"t", "t|time|timestamp|stamp"}, {"x", "x|pos_x"}, {"y", "y"}, {"anchor", "anchor|id"}};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace ips::table;
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  // The first byte picks the options, so separators, header modes and tags are all explored.
  const uint8_t mode = size > 0 ? data[0] : 0;
  ReadOptions o;
  const char seps[] = {',', ';', '\t', kBlanks};
  if (mode & 1) o.separator = seps[(mode >> 1) & 3];
  o.header = static_cast<HeaderMode>((mode >> 3) % 3);
  if (mode & 0x40) o.row_tag = "range2";
  TableReader reader(o);
  ImportTally tally;
  Columns columns;
  RowClock clock(mode & 0x80 ? std::optional<int64_t>(1'700'000'000'000'000) : std::nullopt,
                 (mode & 0x20) ? 820.0 : 0.0);
  size_t start = 0;
  while (start <= text.size()) {
    size_t end = text.find('\n', start);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view line = text.substr(start, end - start);
    const auto kind = reader.feed(line);
    tally.note(reader, kind, line);
    if (kind == TableReader::Kind::kData) {
      if (reader.first_data() && !reader.header().empty())
        columns.set_from_header(reader.header_views(), kKnown);
      if (!printable(columns.describe())) std::abort();
      const auto& f = reader.fields();
      if (f.size() > kMaxFields) std::abort();
      const int t = columns.index("t");
      int64_t us = 0;
      std::optional<int64_t> when;
      if (t >= 0 && static_cast<size_t>(t) < f.size() &&
          parse_time_us(f[static_cast<size_t>(t)], TimeUnit::kMs, us))
        when = us;
      double v = 0;
      for (std::string_view field : f) {
        (void)parse_number(field, v);
        (void)parse_unit(field, Quantity::kPressure);
        (void)parse_iso8601_us(field, us);
      }
      if (clock.next(when)) {
        ++tally.rows;
        ++tally.messages;
      } else {
        tally.reject(reader.line_number(), line, "no time");
      }
    }
    start = end + 1;
  }
  std::vector<std::string_view> list;
  (void)columns.set_from_list(text.substr(0, 64), kKnown);
  const std::string verdict =
      import_verdict(tally, {"fuzz.csv", columns.describe(), o.separator, true, true});
  if (!printable(verdict) || !printable(separator_hint(text.substr(0, 200), o.separator)))
    std::abort();
  return 0;
}
