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
      // An exchange's raw timestamps (device ticks) and round-trip/reply times.
      {"poll_tx", "polltx|polltxts|polltxtime|polltxtimestamp"},
      {"poll_rx", "pollrx|pollrxts|pollrxtime|pollrxtimestamp"},
      {"resp_tx", "resptx|resptxts|resptxtime|resptxtimestamp|responsetx|responsetxts"},
      {"resp_rx", "resprx|resprxts|resprxtime|resprxtimestamp|responserx|responserxts"},
      {"final_tx", "finaltx|finaltxts|finaltxtime|finaltxtimestamp"},
      {"final_rx", "finalrx|finalrxts|finalrxtime|finalrxtimestamp"},
      {"rtd_init", "rtdinit|rtdinitiator"},
      {"rtd_resp", "rtdresp|rtdresponder"},
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

// The stamp columns in exchange order (uwb_twr_timestamps_t.stamps).
constexpr const char* kStampColumns[6] = {"poll_tx", "poll_rx", "resp_tx",
                                          "resp_rx", "final_tx", "final_rx"};

// A counter reading: an integer (a trailing ".0" allowed, as a float column writes it) that a
// `bits`-wide counter can hold, signed or unsigned.
bool stamp_field(std::string_view f, int bits, int64_t& out) {
  double v = 0;
  if (!table::parse_number(f, v) || v != std::floor(v) || std::fabs(v) > 4.0e18) return false;
  out = static_cast<int64_t>(v);
  return twr::fits_counter(out, bits);
}

// The stamps of a row (4 or 6 by the columns mapped), checked against rtd_init and rtd_resp when
// the row has them. Empty when usable, else why not.
std::string row_stamps(const Row& row, int bits, uwb_twr_timestamps_t& x, twr::Stamps& s) {
  x.n_stamps = static_cast<int8_t>(row.has("final_tx") ? 6 : 4);
  for (int k = 0; k < 6; ++k) x.stamps[k] = 0;
  for (int k = 0; k < x.n_stamps; ++k) {
    const std::string_view f = row.field(kStampColumns[k]);
    if (!stamp_field(f, bits, x.stamps[k]))
      return std::string(kStampColumns[k]) + " " + quoted_field(f) + " is not an integer reading of a " +
             std::to_string(bits) + "-bit counter (--counter-bits)";
  }
  s = twr::Stamps{x.stamps[0], x.stamps[1], x.stamps[2], x.stamps[3], x.stamps[4], x.stamps[5]};
  const twr::Intervals iv = twr::intervals(s, bits);
  const struct {
    const char* column;
    int64_t expected;
    const char* what;
  } checks[] = {{"rtd_init", iv.ra, "resp_rx - poll_tx"}, {"rtd_resp", iv.db, "resp_tx - poll_rx"}};
  for (const auto& c : checks) {
    if (!row.has(c.column) || missing_field(row.field(c.column))) continue;
    int64_t v = 0;
    if (!stamp_field(row.field(c.column), bits, v))
      return std::string(c.column) + " " + quoted_field(row.field(c.column)) +
             " is not an integer reading of a " + std::to_string(bits) + "-bit counter";
    if (twr::counter_elapsed(v, 0, bits) != c.expected)
      return std::string(c.column) + " " + std::to_string(v) + " is not " + c.what + " (" +
             std::to_string(c.expected) + "): the stamps do not belong together";
  }
  return "";
}

}  // namespace

RangeFile read_ranges(std::string_view text, const std::string& name, const RangeOptions& options) {
  RangeFile out;
  std::map<std::string, int32_t> seq;  // per "tag\0anchor"
  std::map<std::string, size_t> anchor_index;
  const bool from_stamps = options.range_from == RangeFrom::kTimestamps;
  const int bits = options.counter_bits;
  twr::ClockOffsetTracker clock(options.clock);
  const RowLoopSpec spec{name,
                         options.read,
                         options.time,
                         options.columns,
                         range_columns(),
                         from_stamps ? "poll_tx" : "range",
                         "t,tag,anchor,range",
                         "no range"};
  auto default_list = [&](const table::TableReader&) {
    // A file for one tag or one anchor (--tag, --anchor): the rest of the layout shifts left.
    std::string list = options.time.rate_hz > 0 ? "" : "t,";
    if (options.tag.empty()) list += "tag,";
    if (options.anchor.empty()) list += "anchor,";
    return list + "range";
  };
  auto check = [&](const table::TableReader&, const table::Columns& columns) -> std::string {
    std::string missing;
    if (!columns.has("range") && !from_stamps) missing = "range";
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
    // rtd_init/rtd_resp alone (no stamps) are not used.
    bool any_stamp = false;
    for (const char* c : kStampColumns) any_stamp = any_stamp || columns.has(c);
    for (int k = 0; k < 4 && any_stamp; ++k)
      if (!columns.has(kStampColumns[k]))
        return "timestamp columns need poll_tx, poll_rx, resp_tx and resp_rx (columns " +
               columns.describe() + ")";
    if (columns.has("final_tx") != columns.has("final_rx"))
      return "DS-TWR needs both final_tx and final_rx (columns " + columns.describe() + ")";
    if (from_stamps && !columns.has("poll_tx"))
      return "--range-from timestamps: no timestamp columns (poll_tx, poll_rx, resp_tx, resp_rx; "
             "columns " + columns.describe() + ")";
    if (any_stamp && !twr::valid_counter_bits(bits))
      return "--counter-bits " + std::to_string(bits) + ": expected 16 to 62";
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
    // The file's range: required, unless the range comes from the timestamps.
    double r = std::numeric_limits<double>::quiet_NaN();
    if (row.has("range") && !(from_stamps && missing_field(row.field("range")))) {
      if (!table::parse_number(row.field("range"), r)) {
        row.reject("range " + quoted_field(row.field("range")) + " is not a number");
        return false;
      }
      r = options.unit.to_si(r);
      if (!(r >= 0 && r <= kMaxRangeM)) {
        row.reject("range " + quoted_field(row.field("range")) + " is outside 0..1000 m");
        return false;
      }
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
    // The exchange's stamps: a row whose stamps are bad keeps its range (counted), unless the
    // range is to come from them.
    uwb_twr_timestamps_t x;
    twr::Stamps stamps;
    bool has_stamps = false;
    if (row.has("poll_tx")) {
      const std::string why = row_stamps(row, bits, x, stamps);
      if (why.empty()) {
        has_stamps = true;
      } else if (from_stamps) {
        row.reject(why);
        return false;
      } else {
        if (out.twr.bad++ == 0) {
          out.twr.first_bad_line = out.tally.lines;
          out.twr.first_bad_reason = why;
        }
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
    if (has_stamps) {
      x.utime = m.utime;
      x.source = m.source;
      x.tag_id = m.tag_id;
      x.anchor_id = m.anchor_id;
      x.seq = m.seq;
      x.tick_s = options.tick_s;
      x.counter_bits = static_cast<int8_t>(bits);
      x.reported_range_m = r;
      const twr::Intervals iv = twr::intervals(stamps, bits);
      double tof = 0, offset = std::numeric_limits<double>::quiet_NaN();
      if (x.n_stamps == 6) {
        ++out.twr.ds;
        tof = twr::ds_twr_tof_ticks(iv);
        offset = twr::ds_twr_clock_offset(iv);
      } else {
        ++out.twr.ss;
        const auto o = clock.update(key, m.utime, stamps.poll_tx, stamps.poll_rx, bits,
                                    options.tick_s);
        if (o) offset = *o;
        else ++out.twr.no_offset;
        tof = twr::ss_twr_tof_ticks(iv, o.value_or(0.0));
      }
      const double range = twr::ticks_to_m(tof, options.tick_s);
      x.clock_offset_ppm = std::isfinite(offset) ? offset * 1e6 : offset;
      x.range_m = std::isfinite(range) && range >= kMinStampRangeM && range <= kMaxRangeM
                      ? range
                      : std::numeric_limits<double>::quiet_NaN();
      if (std::isnan(x.range_m)) ++out.twr.no_range;
      out.exchanges.push_back(x);
      ++out.twr.exchanges;
      out.twr.clock = clock.tally();
      if (from_stamps) {
        if (std::isnan(x.range_m) || x.range_m < 0) {
          row.reject("the timestamps give no range in 0..1000 m (" +
                     (std::isnan(range) ? std::string("none") : std::to_string(range) + " m") + ")");
          return false;
        }
        if (std::isnan(offset)) {
          row.reject("no clock offset yet for tag " + m.tag_id + " and anchor " + m.anchor_id +
                     " (SS-TWR: the pair's first exchange, or one after a gap)");
          return false;
        }
        m.range_m = x.range_m;
      }
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
