#include "drivers/import/range_rows.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include "core/device_text.hpp"
#include "core/time.hpp"

namespace ips::import {

const std::vector<table::KnownColumn>& range_columns() {
  // Aliases in order of preference; "%time" (a ROS dump's receive time) before "field.stamp".
  static const std::vector<table::KnownColumn> known = {
      {"t", "time|timestamp|t|utime|stamp|timeus|timems|times|timens"},
      {"tag", "tag|tagid|tagaddress|initiator|from|src"},
      {"anchor", "anchor|anchorid|anchoraddress|responder|to|dst|id"},
      {"range", "range|rangem|distance|distancefromtag|dist|distancem|meas"},
      {"rx", "rxpower|rxpowerdbm|rssi|rss|rxlevel|power"},
      {"fp", "fppower|fppowerdbm|rssifp|firstpathpower|fplevel|fp"},
      {"seq", "seq|sequence|seqnum|sequencenumber"},
      {"quality", "quality|qf|q"},
      {"ax", "anchorx|ax|x|posx"},
      {"ay", "anchory|ay|y|posy"},
      {"az", "anchorz|az|z|posz"},
  };
  return known;
}

double AnchorSeen::spread() const {
  double s = 0;
  for (int k = 0; k < 3; ++k) s = std::max(s, max[k] - min[k]);
  return s;
}

namespace {

// An optional power field: NaN when missing; false when present but not a power in dBm.
bool power_field(std::string_view f, float& out) {
  if (missing_field(f)) {
    out = std::numeric_limits<float>::quiet_NaN();
    return true;
  }
  double v = 0;
  if (!table::parse_number(f, v) || v < -200.0 || v > 50.0) return false;
  out = static_cast<float>(v);
  return true;
}

}  // namespace

RangeFile read_ranges(std::string_view text, const std::string& name,
                      const RangeOptions& options) {
  RangeFile out;
  const auto& known = range_columns();
  table::TableReader reader(options.read);
  table::Columns columns;
  RowTimes times(options.time);
  std::map<std::string, int32_t> seq;  // per "tag\0anchor"
  std::map<std::string, size_t> anchor_index;
  bool failed = false;

  for_each_line(text, [&](std::string_view line) {
    if (failed) return;
    const auto kind = reader.feed(line);
    out.tally.note(reader, kind, line);
    if (kind != table::TableReader::Kind::kData) return;

    if (reader.first_data()) {
      if (!options.columns.empty()) {
        const std::string why = columns.set_from_list(options.columns, known);
        if (!why.empty()) {
          out.error = name + ": --columns: " + why;
          failed = true;
          return;
        }
      } else if (!reader.header().empty() && columns.set_from_header(reader.header_views(), known) > 0 &&
                 columns.has("range")) {
        // mapped by name
      } else {
        columns.set_from_list(options.time.rate_hz > 0 ? "tag,anchor,range" : "t,tag,anchor,range",
                              known);
        if (!options.tag.empty() || !options.anchor.empty()) {
          // A file for one tag or one anchor: the rest of the default layout shifts left.
          std::string list = options.time.rate_hz > 0 ? "" : "t,";
          if (options.tag.empty()) list += "tag,";
          if (options.anchor.empty()) list += "anchor,";
          list += "range";
          columns.set_from_list(list, known);
        }
      }
      std::string missing;
      if (!columns.has("range")) missing = "range";
      else if (!columns.has("t") && options.time.rate_hz <= 0) missing = "t";
      else if (!columns.has("tag") && options.tag.empty()) missing = "tag";
      else if (!columns.has("anchor") && options.anchor.empty()) missing = "anchor";
      if (!missing.empty()) {
        out.error = name + ": no " + missing + " column (columns " + columns.describe() + "); ";
        if (missing == "tag") out.error += "give --tag T for a file of one tag";
        else if (missing == "anchor") out.error += "give --anchor A for a file of one anchor";
        else if (missing == "t") out.error += "name it with --columns, or give --rate HZ";
        else out.error += "name the columns with --columns t,tag,anchor,range[,rx,fp]";
        failed = true;
        return;
      }
      if (columns.has("ax") != columns.has("ay")) {
        out.error = name + ": anchor positions need both ax and ay (columns " +
                    columns.describe() + ")";
        failed = true;
        return;
      }
      out.columns = columns.describe();
    }

    const auto& f = reader.fields();
    if (static_cast<int>(f.size()) < columns.needed()) {
      out.tally.reject(reader.line_number(), line,
                       std::to_string(f.size()) + " fields, expected at least " +
                           std::to_string(columns.needed()) + " (" + columns.describe() + ")");
      return;
    }
    auto field = [&](const char* col) -> std::string_view {
      const int i = columns.index(col);
      return i < 0 ? std::string_view() : f[static_cast<size_t>(i)];
    };

    uwb_range_t m;
    m.source = options.source;
    m.tag_id = columns.has("tag") ? std::string(field("tag")) : options.tag;
    m.anchor_id = columns.has("anchor") ? std::string(field("anchor")) : options.anchor;
    if (!valid_device_id(m.tag_id) || !valid_device_id(m.anchor_id)) {
      out.tally.reject(reader.line_number(), line,
                       "tag or anchor id " +
                           quoted_field(valid_device_id(m.tag_id) ? m.anchor_id : m.tag_id) +
                           " is not 1 to 32 of A-Za-z0-9_.:-");
      return;
    }
    double r = 0;
    if (!table::parse_number(field("range"), r)) {
      out.tally.reject(reader.line_number(), line,
                       "range " + quoted_field(field("range")) + " is not a number");
      return;
    }
    r = options.unit.to_si(r);
    if (!(r >= 0 && r <= kMaxRangeM)) {
      out.tally.reject(reader.line_number(), line,
                       "range " + quoted_field(field("range")) + " is outside 0..1000 m");
      return;
    }
    m.range_m = r;
    if (!power_field(field("rx"), m.rx_power_dbm) || !power_field(field("fp"), m.fp_power_dbm)) {
      out.tally.reject(reader.line_number(), line, "a power is not a number in -200..50 dBm");
      return;
    }
    m.quality = std::numeric_limits<float>::quiet_NaN();
    if (columns.has("quality") && !missing_field(field("quality"))) {
      double q = 0;
      if (!table::parse_number(field("quality"), q) || q < 0 || q > 1) {
        out.tally.reject(reader.line_number(), line, "quality is not a number in 0..1");
        return;
      }
      m.quality = static_cast<float>(q);
    }
    double pos[3] = {0, 0, 0};
    bool has_z = false;
    if (columns.has("ax")) {
      if (!table::parse_number(field("ax"), pos[0]) || !table::parse_number(field("ay"), pos[1])) {
        out.tally.reject(reader.line_number(), line, "anchor x or y is not a number");
        return;
      }
      if (columns.has("az") && !missing_field(field("az"))) {
        if (!table::parse_number(field("az"), pos[2])) {
          out.tally.reject(reader.line_number(), line, "anchor z is not a number");
          return;
        }
        has_z = true;
      }
      for (double& p : pos) p = options.unit.to_si(p);
      if (!(std::fabs(pos[0]) <= 1e6 && std::fabs(pos[1]) <= 1e6 && std::fabs(pos[2]) <= 1e6)) {
        out.tally.reject(reader.line_number(), line, "anchor position beyond 1e6 m");
        return;
      }
    }
    int64_t seq_value = -1;
    if (columns.has("seq") && !missing_field(field("seq"))) {
      if (!parse_integer(field("seq"), seq_value) || seq_value < 0 ||
          seq_value > std::numeric_limits<int32_t>::max()) {
        out.tally.reject(reader.line_number(), line, "seq is not an integer 0..2^31-1");
        return;
      }
    }
    std::string reason;
    const auto t = times.next(field("t"), reason);
    if (!t) {
      out.tally.reject(reader.line_number(), line, reason);
      return;
    }
    if (!plausible_utime(*t)) {
      out.tally.reject(reader.line_number(), line, "time not after 1970 or beyond 2096");
      return;
    }
    m.utime = *t;

    const std::string key = m.tag_id + '\0' + m.anchor_id;
    if (seq_value >= 0) {
      m.seq = static_cast<int32_t>(seq_value);
    } else {
      auto [it, added] = seq.emplace(key, 0);
      if (!added) it->second = it->second == std::numeric_limits<int32_t>::max() ? 0 : it->second + 1;
      m.seq = it->second;
    }
    if (std::find(out.tags.begin(), out.tags.end(), m.tag_id) == out.tags.end())
      out.tags.push_back(m.tag_id);
    if (columns.has("ax")) {
      auto [it, added] = anchor_index.emplace(m.anchor_id, out.anchors.size());
      if (added) {
        AnchorSeen a;
        a.id = m.anchor_id;
        for (int k = 0; k < 3; ++k) a.min[k] = a.max[k] = pos[k];
        out.anchors.push_back(a);
      }
      AnchorSeen& a = out.anchors[it->second];
      ++a.rows;
      a.has_z = a.has_z || has_z;
      for (int k = 0; k < 3; ++k) {
        a.sum[k] += pos[k];
        a.min[k] = std::min(a.min[k], pos[k]);
        a.max[k] = std::max(a.max[k], pos[k]);
      }
    }
    out.ranges.push_back(std::move(m));
    ++out.tally.rows;
    ++out.tally.messages;
  });

  out.time_unit = times.describe();
  out.relative_times = times.relative();
  if (failed) return out;
  table::ImportExpectation expected;
  expected.input = name;
  expected.columns = out.columns.empty() ? "t,tag,anchor,range" : out.columns;
  expected.separator =
      reader.separator_known() ? std::optional<char>(reader.separator()) : options.read.separator;
  expected.separator_given = options.read.separator.has_value();
  expected.time_needed = options.time.rate_hz <= 0;
  out.error = table::import_verdict(out.tally, expected);
  if (out.error.empty() && out.ranges.empty())
    out.error = name + ": no range" + (out.tally.lines == 0 ? " (an empty file)" : "");
  return out;
}

}  // namespace ips::import
