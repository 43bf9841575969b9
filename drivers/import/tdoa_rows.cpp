#include "drivers/import/tdoa_rows.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/device_text.hpp"
#include "core/time.hpp"
#include "drivers/import/row_loop.hpp"

namespace ips::import {

const std::vector<table::KnownColumn>& tdoa_columns() {
  static const std::vector<table::KnownColumn> known = {
      {"t", "time|timestamp|t|utime|stamp|ttdoa|timeus|timems|times|timens"},
      {"tag", "tag|tagid|tagaddress"},
      {"a", "a|anchora|ida|anchor1|anchorida|from"},
      {"b", "b|anchorb|idb|anchor2|anchoridb|to"},
      {"diff", "diff|diffm|tdoa|tdoameas|tdoam|distancediff|rangediff|dd"},
      {"sigma", "sigma|sigmam|std|stddev|stdm"},
      {"quality", "quality|qf|q"},
      {"seq", "seq|sequence|seqnum|sequencenumber"},
  };
  return known;
}

TdoaFile read_tdoa(std::string_view text, const std::string& name, const TdoaOptions& options) {
  TdoaFile out;
  int32_t next_seq = 0;
  const RowLoopSpec spec{name,   options.read, options.time,  options.columns, tdoa_columns(),
                         "diff", "t,a,b,diff", "no difference"};
  auto default_list = [&](const table::TableReader&) {
    return std::string(options.time.rate_hz > 0 ? "" : "t,") + "a,b,diff";
  };
  auto check = [&](const table::TableReader&, const table::Columns& columns) -> std::string {
    std::string missing;
    if (!columns.has("diff")) missing = "diff";
    else if (!columns.has("a")) missing = "a";
    else if (!columns.has("b")) missing = "b";
    else if (!columns.has("t") && options.time.rate_hz <= 0) missing = "t";
    else if (!columns.has("tag") && options.tag.empty()) missing = "tag";
    if (missing.empty()) return "";
    std::string why = "no " + missing + " column (columns " + columns.describe() + "); ";
    if (missing == "tag") why += "give --tag T for a file of one tag";
    else if (missing == "t") why += "name it with --columns, or give --rate HZ";
    else why += "name the columns with --columns t,a,b,diff[,sigma] (UTIL: t_tdoa,idA,idB,tdoa_meas)";
    return why;
  };
  read_rows(text, spec, out, default_list, check, [&](const Row& row) {
    // A wide file's row of another sensor: its TDoA fields are all empty.
    if (missing_field(row.field("diff")) && missing_field(row.field("a")) &&
        missing_field(row.field("b"))) {
      ++out.other_rows;
      ++out.tally.skipped;
      return false;
    }
    uwb_tdoa_t m;
    m.source = options.source;
    m.tag_id = row.has("tag") ? std::string(row.field("tag")) : options.tag;
    // Anchor ids as the file writes them; UTIL writes 0.0 for anchor 0 in some exports.
    auto anchor_id = [](std::string_view f) {
      std::string id(f);
      if (id.size() > 2 && id.compare(id.size() - 2, 2, ".0") == 0 &&
          std::all_of(id.begin(), id.end() - 2, [](char c) { return c >= '0' && c <= '9'; }))
        id.resize(id.size() - 2);
      return id;
    };
    m.anchor_a = anchor_id(row.field("a"));
    m.anchor_b = anchor_id(row.field("b"));
    for (const std::string* id : {&m.tag_id, &m.anchor_a, &m.anchor_b}) {
      if (!valid_device_id(*id)) {
        row.reject("id " + quoted_field(*id) + " is not 1 to 32 of A-Za-z0-9_.:-");
        return false;
      }
    }
    if (m.anchor_a == m.anchor_b) {
      row.reject("anchor_a and anchor_b are the same anchor " + quoted_field(m.anchor_a));
      return false;
    }
    double d = 0;
    if (!table::parse_number(row.field("diff"), d)) {
      row.reject("difference " + quoted_field(row.field("diff")) + " is not a number");
      return false;
    }
    d = options.unit.to_si(d);
    if (!(std::fabs(d) <= kMaxTdoaM)) {
      row.reject("difference " + quoted_field(row.field("diff")) + " is beyond +-1000 m");
      return false;
    }
    m.diff_m = d;
    m.sigma_m = std::numeric_limits<float>::quiet_NaN();
    if (row.has("sigma") && !missing_field(row.field("sigma"))) {
      double s = 0;
      if (!table::parse_number(row.field("sigma"), s) || !(options.unit.to_si(s) > 0) ||
          options.unit.to_si(s) > 100) {
        row.reject("sigma " + quoted_field(row.field("sigma")) + " is not a number in (0, 100] m");
        return false;
      }
      m.sigma_m = static_cast<float>(options.unit.to_si(s));
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
    if (seq_value >= 0) {
      m.seq = static_cast<int32_t>(seq_value);
    } else {
      m.seq = next_seq;
      next_seq = next_seq == std::numeric_limits<int32_t>::max() ? 0 : next_seq + 1;
    }
    for (const std::string* id : {&m.anchor_a, &m.anchor_b})
      if (std::find(out.anchors.begin(), out.anchors.end(), *id) == out.anchors.end())
        out.anchors.push_back(*id);
    out.pairs.push_back(std::move(m));
    ++out.tally.messages;
    return true;
  });
  return out;
}

}  // namespace ips::import
