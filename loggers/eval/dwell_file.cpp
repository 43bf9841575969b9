#include "loggers/eval/dwell_file.hpp"

#include <cmath>

namespace ips::eval {

namespace {

// Aliases in order of preference: the BLE dataset's 0409 files have StartTimeISO before
// StartTimestamp, and the epoch number is the exact one.
const std::vector<table::KnownColumn>& known_columns() {
  static const std::vector<table::KnownColumn> known = {
      {"start", "starttimestamp|starttime|start|startts|begin|tstart|from|starttimeiso|startiso"},
      {"end", "endtimestamp|endtime|end|endts|stop|tend|to|endtimeiso|endiso"},
      {"x", "x|xm|posx|positionx"},
      {"y", "y|ym|posy|positiony"},
      {"z", "z|zm|posz|positionz|height"},
      {"tag", "tag|tagid|tagmac|id|mac"},
  };
  return known;
}

// The text in brackets of a header field ("X(cm)" -> "cm", "Start [ms]" -> "ms"); empty if none.
std::string_view bracketed(std::string_view h) {
  const size_t open = h.find_first_of("([{");
  if (open == std::string_view::npos) return {};
  const size_t close = h.find_first_of(")]}", open + 1);
  if (close == std::string_view::npos) return {};
  return h.substr(open + 1, close - open - 1);
}

std::string_view header_of(const table::TableReader& reader, const table::Columns& columns,
                           std::string_view name) {
  const int i = columns.index(name);
  if (i < 0 || static_cast<size_t>(i) >= reader.header().size()) return {};
  return reader.header()[static_cast<size_t>(i)];
}

}  // namespace

DwellFile read_dwell_file(std::string_view text, const std::string& name,
                          const DwellFileOptions& options) {
  DwellFile out;
  table::ReadOptions read_options;
  read_options.separator = options.separator;
  table::TableReader reader(read_options);
  table::Columns columns;
  std::optional<table::TimeUnit> time_unit = options.time_unit;
  table::UnitScale unit = options.unit.value_or(table::UnitScale{});
  bool time_guessed = false;
  int iso_times = 0;

  while (!text.empty()) {
    const size_t nl = text.find('\n');
    std::string_view line = text.substr(0, nl);
    text.remove_prefix(nl == std::string_view::npos ? text.size() : nl + 1);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    const auto kind = reader.feed(line);
    out.tally.note(reader, kind, line);
    if (kind != table::TableReader::Kind::kData) continue;

    if (reader.first_data()) {
      if (!options.columns.empty()) {
        const std::string why = columns.set_from_list(options.columns, known_columns());
        if (!why.empty()) {
          out.error = name + ": --dwell-columns: " + why;
          return out;
        }
      } else if (!reader.header().empty()) {
        columns.set_from_header(reader.header_views(), known_columns());
      } else {
        columns.set_from_list("start,end,x,y", known_columns());
      }
      for (const char* needed : {"start", "end", "x", "y"})
        if (!columns.has(needed)) {
          out.error = name + ": no " + needed + " column" +
                      (options.columns.empty()
                           ? " in the header (columns " + columns.describe() +
                                 "); name them with --dwell-columns start,end,x,y[,z][,tag]"
                           : std::string(" in --dwell-columns"));
          return out;
        }
      out.columns = columns.describe();
      // Units written in the header: "X(cm)", "StartTimestamp(ms)".
      if (!options.unit) {
        const std::string_view u = bracketed(header_of(reader, columns, "x"));
        if (!u.empty())
          if (auto scale = table::parse_unit(u, table::Quantity::kLength)) unit = *scale;
      }
      if (!time_unit) {
        const std::string_view u = bracketed(header_of(reader, columns, "start"));
        if (!u.empty()) time_unit = table::time_unit_from_name(u);
      }
    }

    const auto& f = reader.fields();
    if (static_cast<int>(f.size()) < columns.needed()) {
      out.tally.reject(reader.line_number(), line,
                       std::to_string(f.size()) + " fields, expected at least " +
                           std::to_string(columns.needed()) + " (" + columns.describe() + ")");
      continue;
    }
    auto field = [&](const char* col) { return f[static_cast<size_t>(columns.index(col))]; };

    DwellInterval d;
    bool times_ok = true;
    for (auto [col, t] : {std::pair{"start", &d.start}, std::pair{"end", &d.end}}) {
      const std::string_view v = field(col);
      int64_t us = 0;
      if (table::parse_iso8601_us(v, us)) {
        ++iso_times;
      } else {
        double number = 0;
        if (!time_unit && table::parse_number(v, number)) {
          time_unit = table::guess_epoch_unit(number);
          time_guessed = time_unit.has_value();
        }
        if (!time_unit) {
          out.tally.reject(reader.line_number(), line,
                           std::string(col) + " time '" + table::excerpt(v, 24) +
                               "' is not an epoch time in s, ms, us or ns nor ISO-8601: give "
                               "--dwell-time-unit");
          times_ok = false;
          break;
        }
        if (!table::parse_time_us(v, *time_unit, us)) {
          out.tally.reject(reader.line_number(), line,
                           std::string("bad ") + col + " time '" + table::excerpt(v, 24) + "'");
          times_ok = false;
          break;
        }
      }
      *t = us;
    }
    if (!times_ok) continue;
    if (!plausible_utime(d.start) || !plausible_utime(d.end)) {
      out.tally.reject(reader.line_number(), line, "time before 1970 or beyond 2096");
      continue;
    }
    if (d.end < d.start) {
      out.tally.reject(reader.line_number(), line, "the interval ends before it starts");
      continue;
    }
    double x = 0, y = 0;
    if (!table::parse_number(field("x"), x) || !table::parse_number(field("y"), y)) {
      out.tally.reject(reader.line_number(), line, "x or y is not a number");
      continue;
    }
    d.x = unit.to_si(x);
    d.y = unit.to_si(y);
    if (columns.has("z") && !field("z").empty() && field("z") != "-") {
      double z = 0;
      if (!table::parse_number(field("z"), z)) {
        out.tally.reject(reader.line_number(), line, "z is not a number");
        continue;
      }
      d.z = unit.to_si(z);
    }
    if (!std::isfinite(d.x) || !std::isfinite(d.y) || std::isinf(d.z)) {
      out.tally.reject(reader.line_number(), line, "position out of range");
      continue;
    }
    if (columns.has("tag")) d.tag = std::string(field("tag"));
    out.intervals.push_back(std::move(d));
    ++out.tally.rows;
    ++out.tally.messages;
  }

  out.time_unit = time_unit ? std::string(table::time_unit_name(*time_unit)) +
                                  (time_guessed ? " (guessed)" : "")
                            : std::string(iso_times > 0 ? "ISO-8601" : "-");
  out.unit_factor = unit.factor;
  table::ImportExpectation expected;
  expected.input = name;
  expected.columns = out.columns;
  expected.separator =
      reader.separator_known() ? std::optional<char>(reader.separator()) : options.separator;
  expected.separator_given = options.separator.has_value();
  expected.time_needed = false;  // its hint names --time-unit; our reasons name --dwell-time-unit
  out.error = table::import_verdict(out.tally, expected);
  if (out.error.empty() && out.intervals.empty())
    out.error = name + ": no dwell interval (an empty file?)";
  return out;
}

}  // namespace ips::eval
