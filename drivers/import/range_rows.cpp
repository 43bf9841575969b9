#include "drivers/import/range_rows.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include "core/device_text.hpp"
#include "core/time.hpp"
#include "drivers/import/row_loop.hpp"

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

RangeFile read_ranges(std::string_view text, const std::string& name, const RangeOptions& options) {
  RangeFile out;
  std::map<std::string, int32_t> seq;  // per "tag\0anchor"
  std::map<std::string, size_t> anchor_index;
  const RowLoopSpec spec{
      name,    options.read,         options.time, options.columns, range_columns(),
      "range", "t,tag,anchor,range", "no range"};
  auto default_list = [&](const table::TableReader&) {
    // A file for one tag or one anchor (--tag, --anchor): the rest of the layout shifts left.
    std::string list = options.time.rate_hz > 0 ? "" : "t,";
    if (options.tag.empty()) list += "tag,";
    if (options.anchor.empty()) list += "anchor,";
    return list + "range";
  };
  auto check = [&](const table::TableReader&, const table::Columns& columns) -> std::string {
    std::string missing;
    if (!columns.has("range")) missing = "range";
    else if (!columns.has("t") && options.time.rate_hz <= 0) missing = "t";
    else if (!columns.has("tag") && options.tag.empty()) missing = "tag";
    else if (!columns.has("anchor") && options.anchor.empty()) missing = "anchor";
    if (!missing.empty()) {
      std::string why = "no " + missing + " column (columns " + columns.describe() + "); ";
      if (missing == "tag") why += "give --tag T for a file of one tag";
      else if (missing == "anchor") why += "give --anchor A for a file of one anchor";
      else if (missing == "t") why += "name it with --columns, or give --rate HZ";
      else why += "name the columns with --columns t,tag,anchor,range[,rx,fp]";
      return why;
    }
    if (columns.has("ax") != columns.has("ay"))
      return "anchor positions need both ax and ay (columns " + columns.describe() + ")";
    return "";
  };
  read_rows(text, spec, out, default_list, check, [&](const Row& row) {
    uwb_range_t m;
    m.source = options.source;
    m.tag_id = row.has("tag") ? std::string(row.field("tag")) : options.tag;
    m.anchor_id = row.has("anchor") ? std::string(row.field("anchor")) : options.anchor;
    if (!valid_device_id(m.tag_id) || !valid_device_id(m.anchor_id)) {
      row.reject("tag or anchor id " +
                 quoted_field(valid_device_id(m.tag_id) ? m.anchor_id : m.tag_id) +
                 " is not 1 to 32 of A-Za-z0-9_.:-");
      return false;
    }
    double r = 0;
    if (!table::parse_number(row.field("range"), r)) {
      row.reject("range " + quoted_field(row.field("range")) + " is not a number");
      return false;
    }
    r = options.unit.to_si(r);
    if (!(r >= 0 && r <= kMaxRangeM)) {
      row.reject("range " + quoted_field(row.field("range")) + " is outside 0..1000 m");
      return false;
    }
    m.range_m = r;
    if (!power_field(row.field("rx"), m.rx_power_dbm) ||
        !power_field(row.field("fp"), m.fp_power_dbm)) {
      row.reject("a power is not a number in -200..50 dBm");
      return false;
    }
    m.quality = std::numeric_limits<float>::quiet_NaN();
    if (row.has("quality") && !missing_field(row.field("quality"))) {
      double q = 0;
      if (!table::parse_number(row.field("quality"), q) || q < 0 || q > 1) {
        row.reject("quality is not a number in 0..1");
        return false;
      }
      m.quality = static_cast<float>(q);
    }
    double pos[3] = {0, 0, 0};
    bool has_z = false;
    if (row.has("ax")) {
      if (!table::parse_number(row.field("ax"), pos[0]) ||
          !table::parse_number(row.field("ay"), pos[1])) {
        row.reject("anchor x or y is not a number");
        return false;
      }
      if (row.has("az") && !missing_field(row.field("az"))) {
        if (!table::parse_number(row.field("az"), pos[2])) {
          row.reject("anchor z is not a number");
          return false;
        }
        has_z = true;
      }
      for (double& p : pos) p = options.unit.to_si(p);
      if (!(std::fabs(pos[0]) <= 1e6 && std::fabs(pos[1]) <= 1e6 && std::fabs(pos[2]) <= 1e6)) {
        row.reject("anchor position beyond 1e6 m");
        return false;
      }
    }
    int64_t seq_value = -1;
    if (row.has("seq") && !missing_field(row.field("seq"))) {
      if (!parse_integer(row.field("seq"), seq_value) || seq_value < 0 ||
          seq_value > std::numeric_limits<int32_t>::max()) {
        row.reject("seq is not an integer 0..2^31-1");
        return false;
      }
    }
    const auto t = row.time();
    if (!t) return false;
    m.utime = *t;

    const std::string key = m.tag_id + '\0' + m.anchor_id;
    if (seq_value >= 0) {
      m.seq = static_cast<int32_t>(seq_value);
    } else {
      auto [it, added] = seq.emplace(key, 0);
      if (!added)
        it->second = it->second == std::numeric_limits<int32_t>::max() ? 0 : it->second + 1;
      m.seq = it->second;
    }
    if (std::find(out.tags.begin(), out.tags.end(), m.tag_id) == out.tags.end())
      out.tags.push_back(m.tag_id);
    if (row.has("ax")) {
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
    ++out.tally.messages;
    return true;
  });
  return out;
}

}  // namespace ips::import
