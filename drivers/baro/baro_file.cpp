#include "drivers/baro/baro_file.hpp"

#include <cmath>
#include <cstdio>
#include <ctime>
#include <algorithm>

#include "core/device_text.hpp"
#include "core/text_escape.hpp"
#include "drivers/baro/baro_line_parser.hpp"
#include "drivers/baro/sensor_spec.hpp"

namespace ips::baro {

namespace {

using table::ImportTally;
using table::TableReader;

std::string_view trim_line(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r'))
    s.remove_suffix(1);
  return s;
}

// "-----------" (a terminal logger's rule line, before and after the data).
bool is_rule(std::string_view line) {
  if (line.size() < 3) return false;
  for (char c : line)
    if (c != '-' && c != '=') return false;
  return true;
}

std::vector<std::string_view> split_list(std::string_view s) {
  std::vector<std::string_view> out;
  for (size_t start = 0;;) {
    const size_t comma = s.find(',', start);
    std::string_view part = s.substr(start, comma == std::string_view::npos ? s.npos : comma - start);
    while (!part.empty() && part.front() == ' ') part.remove_prefix(1);
    while (!part.empty() && part.back() == ' ') part.remove_suffix(1);
    out.push_back(part);
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  return out;
}

const char* role_suffix(FileColumn::Role r) {
  switch (r) {
    case FileColumn::Role::kPressure:
      return "p";
    case FileColumn::Role::kTemperature:
      return "t";
    case FileColumn::Role::kHumidity:
      return "h";
    default:
      return "";
  }
}

std::string iso_utc(int64_t utime) {
  const auto secs = static_cast<time_t>(utime / 1'000'000);
  std::tm tm{};
  if (!gmtime_r(&secs, &tm)) return std::to_string(utime) + " us";
  char buf[40];
  std::snprintf(buf, sizeof buf, "%04d-%02d-%02dT%02d:%02d:%02dZ", tm.tm_year + 1900, tm.tm_mon + 1,
                tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec);
  return buf;
}

std::string fixed(double v, int decimals) {
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

// A row's value of one column; false with the reason.
bool column_value(std::string_view field, const FileColumn& c, double& out, std::string& reason) {
  static constexpr const char* kWhat[] = {"", "time", "pressure", "temperature", "humidity"};
  const char* what = kWhat[static_cast<int>(c.role)];
  if (field.empty()) {
    reason = std::string(what) + " is empty";
    return false;
  }
  double v = 0;
  if (!table::parse_number(field, v)) {
    reason = std::string(what) + " " + quoted_field(field) + " is not a number";
    return false;
  }
  out = c.unit.to_si(v);
  if (c.role == FileColumn::Role::kPressure) {
    // parse_unit gives Pa for pressure.
  } else if (c.role == FileColumn::Role::kHumidity) {
    out *= 100.0;  // a ratio -> %
  }
  return true;
}

}  // namespace

bool FileLayout::has_time() const {
  for (const FileColumn& c : columns)
    if (c.role == FileColumn::Role::kTime) return true;
  return false;
}

std::string FileLayout::describe() const {
  if (columns.empty()) return "";
  std::string out;
  for (size_t i = 0; i < columns.size(); ++i) {
    const FileColumn& c = columns[i];
    if (i > 0) out += ',';
    if (c.role == FileColumn::Role::kSkip) {
      out += '-';
    } else if (c.role == FileColumn::Role::kTime) {
      out += "time";
    } else if (c.sensor == 0) {
      out += role_suffix(c.role);
    } else {
      out += sensors[static_cast<size_t>(c.sensor)] + "." + role_suffix(c.role);
    }
  }
  return out;
}

bool parse_file_layout(std::string_view columns, std::string_view units, const std::string& device,
                       FileLayout& out, std::string& reason) {
  out = FileLayout{};
  if (!valid_sensor_id(device)) {
    reason = "--device '" + printable(device) + "' is not a sensor id (1 to 32 of A-Za-z0-9_.:-)";
    return false;
  }
  out.sensors.push_back(device);
  if (columns.empty()) {
    if (!units.empty()) {
      reason = "--units goes with --columns (the P/T line format is in Pa and degC)";
      return false;
    }
    return true;
  }
  const std::vector<std::string_view> names = split_list(columns);
  std::vector<std::string_view> unit_specs;
  if (!units.empty()) {
    unit_specs = split_list(units);
    if (unit_specs.size() != names.size()) {
      reason = "--units has " + std::to_string(unit_specs.size()) + " entries for " +
               std::to_string(names.size()) + " columns (one per column, '-' for the default)";
      return false;
    }
  }
  if (names.size() > table::kMaxFields) {
    reason = "--columns: more than 512 columns";
    return false;
  }
  std::vector<std::string> seen;
  bool any_pressure = false;
  for (size_t i = 0; i < names.size(); ++i) {
    const std::string_view name = names[i];
    FileColumn c;
    if (name == "-") {
      out.columns.push_back(c);
      continue;
    }
    std::string key;
    if (name == "time") {
      c.role = FileColumn::Role::kTime;
      key = "time";
    } else {
      std::string_view sensor = name, field = "p";
      const size_t dot = name.rfind('.');
      if (name == "p" || name == "t" || name == "h") {
        sensor = device;
        field = name;
      } else if (dot != std::string_view::npos && dot + 2 == name.size() &&
                 (name[dot + 1] == 'p' || name[dot + 1] == 't' || name[dot + 1] == 'h')) {
        sensor = name.substr(0, dot);
        field = name.substr(dot + 1);
      }
      if (!valid_sensor_id(sensor)) {
        reason = "--columns: '" + printable(name) +
                 "' is not a column name (p, t, h, time, -, NAME, NAME.p, NAME.t, NAME.h; NAME "
                 "1 to 32 of A-Za-z0-9_.:-)";
        return false;
      }
      c.role = field == "p"   ? FileColumn::Role::kPressure
               : field == "t" ? FileColumn::Role::kTemperature
                              : FileColumn::Role::kHumidity;
      int index = -1;
      for (size_t k = 0; k < out.sensors.size(); ++k)
        if (out.sensors[k] == sensor) index = static_cast<int>(k);
      if (index < 0) {
        index = static_cast<int>(out.sensors.size());
        out.sensors.emplace_back(sensor);
      }
      c.sensor = index;
      key = std::string(sensor) + "." + std::string(field);
      if (c.role == FileColumn::Role::kPressure) any_pressure = true;
    }
    for (const std::string& s : seen)
      if (s == key) {
        reason = "--columns: '" + printable(name) + "' is given twice";
        return false;
      }
    seen.push_back(key);
    const std::string_view spec = unit_specs.empty() ? std::string_view() : unit_specs[i];
    if (!spec.empty() && spec != "-") {
      if (c.role == FileColumn::Role::kTime) {
        out.time_unit = table::time_unit_from_name(spec);
        if (!out.time_unit) {
          reason = "--units: the time column's unit '" + printable(spec) +
                   "' is not s, ms, us or ns";
          return false;
        }
      } else {
        const table::Quantity q = c.role == FileColumn::Role::kPressure ? table::Quantity::kPressure
                                  : c.role == FileColumn::Role::kTemperature
                                      ? table::Quantity::kTemperature
                                      : table::Quantity::kRatio;
        const auto unit = table::parse_unit(spec, q);
        if (!unit) {
          reason = "--units: '" + printable(spec) + "' for column '" + printable(name) +
                   "' is not a unit of " + role_suffix(c.role) + " (" + table::unit_names(q) +
                   ", optionally after a factor: 0.001hPa)";
          return false;
        }
        c.unit = *unit;
      }
    } else if (c.role == FileColumn::Role::kHumidity) {
      c.unit = table::UnitScale{0.01, 0.0};  // % by default
    }
    out.columns.push_back(c);
  }
  if (!any_pressure) {
    reason = "--columns '" + printable(columns) + "' has no pressure column (p or NAME)";
    return false;
  }
  // A sensor with a temperature or humidity but no pressure gives nothing.
  for (size_t k = 0; k < out.sensors.size(); ++k) {
    bool has_p = false;
    for (const FileColumn& c : out.columns)
      if (c.sensor == static_cast<int>(k) && c.role == FileColumn::Role::kPressure) has_p = true;
    if (!has_p && k > 0) {
      reason = "--columns: sensor '" + out.sensors[k] + "' has no pressure column (" +
               out.sensors[k] + ".p)";
      return false;
    }
  }
  return true;
}

bool parse_banner_date(std::string_view line, int64_t& us) {
  line = trim_line(line);
  if (line.substr(0, 5) != "Date:") return false;
  line.remove_prefix(5);
  int a = 0, b = 0, c = 0, hh = 0, mm = 0, ss = 0;
  const std::string text(line.substr(0, 64));
  char tail = 0;
  if (std::sscanf(text.c_str(), " %d-%d-%d - %d:%d:%d %c", &a, &b, &c, &hh, &mm, &ss, &tail) != 6)
    return false;
  int year = a, month = b, day = c;
  if (c >= 1000 && a <= 31) year = c, day = a;  // DD-MM-YYYY
  if (year < 1970 || year > 9999) return false;
  char iso[40];
  std::snprintf(iso, sizeof iso, "%04d-%02d-%02dT%02d:%02d:%02d", year, month, day, hh, mm, ss);
  return table::parse_iso8601_us(iso, us);
}

double SensorTally::mean_p() const {
  return samples > 0 ? sum_p / static_cast<double>(samples) : kNaN;
}

double SensorTally::std_p() const {
  if (samples < 2) return kNaN;
  const double n = static_cast<double>(samples);
  const double m = sum_p / n;
  return std::sqrt(std::max(0.0, sum_p2 / n - m * m));
}

FileResult read_baro_file(std::string_view text, const FileOptions& o) {
  FileResult r;
  const FileLayout& layout = o.layout;
  r.sensors.resize(layout.sensors.size());
  ImportTally& tally = r.tally;
  TableReader reader(o.read);
  const bool table_mode = !layout.columns.empty();
  const bool time_column = layout.has_time();
  std::optional<table::TimeUnit> time_unit = layout.time_unit;
  table::RowClock clock(o.start_utime, 0.0);
  // Rows without a time column get theirs once the row count and the end date are known.
  std::vector<int64_t> row_of_sample;
  int64_t preamble_lines = 0;
  bool line_data_seen = false;

  auto reject_sensor = [&](int sensor, int64_t line_number, const std::string& why) {
    SensorTally& s = r.sensors[static_cast<size_t>(sensor)];
    if (s.rejected++ == 0) {
      s.first_rejected_line = line_number;
      s.first_reason = why;
    }
  };
  auto accept = [&](int sensor, const BaroReading& reading, int64_t utime) {
    SensorTally& s = r.sensors[static_cast<size_t>(sensor)];
    ++s.samples;
    s.sum_p += reading.pressure_pa;
    s.sum_p2 += reading.pressure_pa * reading.pressure_pa;
    if (!std::isnan(reading.temperature_c)) s.sum_t += reading.temperature_c, ++s.n_t;
    r.samples.push_back({sensor, utime, reading});
    row_of_sample.push_back(r.data_rows - 1);
  };

  int64_t line_number = 0;
  std::vector<BaroReading> readings(layout.sensors.size());
  std::vector<std::string> problems(layout.sensors.size());
  for (size_t pos = 0; pos < text.size();) {
    const size_t nl = text.find('\n', pos);
    const std::string_view raw = text.substr(pos, nl == std::string_view::npos ? nl : nl - pos);
    pos = nl == std::string_view::npos ? text.size() : nl + 1;
    const std::string_view line = trim_line(raw);
    int64_t date = 0;
    // The terminal logger's lines: its dates, rule lines and "End log file".
    if (parse_banner_date(line, date) || line == "End log file" || is_rule(line)) {
      // The terminal logger's lines: before the data they are its banner, after it its trailer.
      ++tally.lines;
      ++line_number;
      if (table_mode) {
        reader.feed("");  // keeps the reader's line numbers right
      }
      if (line != "End log file" && !is_rule(line)) {
        if (r.data_rows == 0) {
          if (!r.banner_start) r.banner_start = date;
        } else {
          r.banner_end = date;
        }
      }
      if (r.data_rows == 0) {
        if (tally.preamble++ == 0) tally.first_preamble = table::excerpt(line);
      } else {
        ++tally.skipped;
      }
      continue;
    }
    if (!table_mode) {
      ++line_number;
      ++tally.lines;
      if (line.empty() || line.front() == '#') {
        ++tally.skipped;
        continue;
      }
      const BaroLineResult lr = parse_baro_line(line);
      if (lr.kind == BaroLineResult::Kind::kComment) {
        ++tally.skipped;
        continue;
      }
      const bool looks_like_sample = line.front() == 'P' || line.front() == 'T' ||
                                     line.front() == 'H';
      if (lr.kind == BaroLineResult::Kind::kError && !line_data_seen && !looks_like_sample &&
          preamble_lines < 64) {
        ++preamble_lines;
        if (tally.preamble++ == 0) tally.first_preamble = table::excerpt(line);
        continue;
      }
      line_data_seen = true;
      ++r.data_rows;
      if (lr.kind == BaroLineResult::Kind::kError) {
        reject_sensor(0, line_number, lr.reason);
        tally.reject(line_number, line, lr.reason);
        continue;
      }
      ++tally.rows;
      accept(0, lr.reading, 0);
      continue;
    }
    const TableReader::Kind kind = reader.feed(line);
    line_number = reader.line_number();
    tally.note(reader, kind, line);
    if (kind != TableReader::Kind::kData) continue;
    ++r.data_rows;
    const std::vector<std::string_view>& f = reader.fields();
    if (static_cast<int>(f.size()) < layout.needed()) {
      tally.reject(line_number, line,
                   std::to_string(f.size()) + " fields, expected " +
                       std::to_string(layout.needed()) + " (" + layout.describe() + ")");
      continue;
    }
    std::optional<int64_t> utime;
    std::string time_problem;
    for (size_t k = 0; k < readings.size(); ++k) {
      readings[k] = BaroReading{};
      problems[k].clear();
    }
    for (size_t i = 0; i < layout.columns.size(); ++i) {
      const FileColumn& c = layout.columns[i];
      if (c.role == FileColumn::Role::kSkip) continue;
      if (c.role == FileColumn::Role::kTime) {
        if (!time_unit) {
          double v = 0;
          time_unit = table::TimeUnit::kS;
          if (table::parse_number(f[i], v))
            if (const auto guess = table::guess_epoch_unit(v)) time_unit = guess;
        }
        int64_t t = 0;
        if (table::parse_time_us(f[i], *time_unit, t))
          utime = clock.next(t);
        if (!utime)
          time_problem = "time " + quoted_field(f[i]) + " is not a time in " +
                         table::time_unit_name(*time_unit) + " or ISO-8601";
        continue;
      }
      const size_t s = static_cast<size_t>(c.sensor);
      if (!problems[s].empty()) continue;
      double v = 0;
      if (!column_value(f[i], c, v, problems[s])) continue;
      if (c.role == FileColumn::Role::kPressure) readings[s].pressure_pa = v;
      if (c.role == FileColumn::Role::kTemperature) readings[s].temperature_c = v;
      if (c.role == FileColumn::Role::kHumidity) readings[s].humidity_pct = v;
    }
    if (!time_problem.empty()) {
      tally.reject(line_number, line, time_problem);
      continue;
    }
    bool any = false;
    std::string first_problem;
    for (size_t s = 0; s < readings.size(); ++s) {
      if (problems[s].empty()) problems[s] = reading_problem(readings[s]);
      if (!problems[s].empty()) {
        const std::string why = layout.sensors.size() > 1
                                    ? layout.sensors[s] + ": " + problems[s]
                                    : problems[s];
        reject_sensor(static_cast<int>(s), line_number, why);
        if (first_problem.empty()) first_problem = why;
        continue;
      }
      any = true;
      accept(static_cast<int>(s), readings[s], utime.value_or(0));
    }
    if (any)
      ++tally.rows;
    else
      tally.reject(line_number, line, first_problem);
  }
  tally.messages = static_cast<int64_t>(r.samples.size());

  if (time_column) {
    r.time_note = "times from the time column (" +
                  std::string(table::time_unit_name(time_unit.value_or(table::TimeUnit::kS))) +
                  (o.start_utime ? ", placed at --file-start)" : ")");
    if (clock.since_boot())
      r.time_note += "; they are not Unix times (before 2001): give --file-start";
    return r;
  }
  // No time column: row k at start + k / rate.
  const std::optional<int64_t> start = o.start_utime ? o.start_utime : r.banner_start;
  const std::optional<int64_t> end = o.end_utime ? o.end_utime : r.banner_end;
  const char* start_from = o.start_utime ? "--file-start" : "the banner's start date";
  const char* end_from = o.end_utime ? "--file-end" : "the trailer's end date";
  if (start && end && *end > *start && r.data_rows > 1)
    r.derived_hz = static_cast<double>(r.data_rows - 1) / (static_cast<double>(*end - *start) * 1e-6);
  const std::string span_text =
      start && end ? std::to_string(r.data_rows) + " rows from " + iso_utc(*start) + " (" +
                         start_from + ") to " + iso_utc(*end) + " (" + end_from + ")"
                   : "";
  if (o.rate_hz > 0) {
    r.rate_hz = o.rate_hz;
    r.time_note = "times from --rate " + format_number(o.rate_hz) + " Hz";
    r.time_note += start ? std::string(" from ") + iso_utc(*start) + " (" + start_from + ")"
                         : std::string(" from 0 (no --file-start and no banner date: not Unix times)");
    if (r.derived_hz > 0)
      r.time_note += "; " + span_text + " say " + fixed(r.derived_hz, 3) + " Hz";
  } else if (r.derived_hz > 0) {
    r.rate_hz = r.derived_hz;
    r.time_note = "times: " + span_text + ", evenly: " + fixed(r.derived_hz, 3) +
                  " Hz (--rate HZ to override)";
  } else if (!r.samples.empty()) {
    r.error = o.name + ": the rows have no time: give --rate HZ (and --file-start T), or " +
              "--columns with a time column" +
              (start ? ", or --file-end T (there is a start date but no end date)" : "");
    return r;
  }
  table::RowClock rows(start.value_or(0), r.rate_hz);
  int64_t next_row = 0, t = 0;
  for (size_t i = 0; i < r.samples.size(); ++i) {
    while (next_row <= row_of_sample[i]) {
      t = rows.next(std::nullopt).value_or(0);
      ++next_row;
    }
    r.samples[i].utime = t;
  }
  return r;
}

}  // namespace ips::baro
