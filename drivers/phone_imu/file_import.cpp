#include "drivers/phone_imu/file_import.hpp"

#include <cmath>
#include <cstdio>

#include "core/time.hpp"

namespace ips::phone_imu {

namespace {

constexpr const char* kSensorName[] = {"accelerometer", "gyroscope", "magnetometer"};
constexpr std::string_view kAxisName[3][3] = {
    {"ax", "ay", "az"}, {"gx", "gy", "gz"}, {"mx", "my", "mz"}};
// Without --file-start, a --rate file's first row: 1 s after the epoch (utime 0 is "unknown").
constexpr int64_t kRateDefaultStartUs = 1'000'000;

double scale_of(int sensor, const UnitScales& u) {
  return sensor == 0 ? u.accel : sensor == 1 ? u.gyro : u.mag;
}

std::string quoted(std::string_view f) { return "'" + table::excerpt(f, 40) + "'"; }

}  // namespace

const std::vector<table::KnownColumn>& file_known_columns() {
  // Header names as the apps write them, normalised by table::normalise_header_name (lower case,
  // units in brackets and _ - . blanks dropped): "time", "Timestamp(ms)", "t_ns", "acc_x",
  // "ACCELEROMETER X (m/s²)", "gyro_x", "magnetic_field_x"...
  static const std::vector<table::KnownColumn> known = {
      {"t",
       "t|time|timestamp|tns|tms|tus|ts|timestampns|timestampms|timestampus|timestamps|timens|"
       "timems|timeus|times|utime|seconds|secondselapsed"},
      {"ax", "ax|accx|accelx|accelerationx|accelerometerx|accelerometer x"},
      {"ay", "ay|accy|accely|accelerationy|accelerometery|accelerometer y"},
      {"az", "az|accz|accelz|accelerationz|accelerometerz|accelerometer z"},
      {"gx", "gx|gyrx|gyrox|gyroscopex|wx|angularratex"},
      {"gy", "gy|gyry|gyroy|gyroscopey|wy|angularratey"},
      {"gz", "gz|gyrz|gyroz|gyroscopez|wz|angularratez"},
      {"mx", "mx|magx|magneticx|magnetometerx|magneticfieldx"},
      {"my", "my|magy|magneticy|magnetometery|magneticfieldy"},
      {"mz", "mz|magz|magneticz|magnetometerz|magneticfieldz"},
  };
  return known;
}

std::string file_layout_from(const table::Columns& columns, bool rate, bool need_accel,
                             FileLayout& layout) {
  FileLayout l;
  l.time_column = columns.index("t");
  if (rate && l.time_column >= 0)
    return "--rate is for a file without a time column, and the columns have t";
  if (!rate && l.time_column < 0)
    return "no t (time) column: give one in --columns, or --rate HZ for a file without times";
  bool any = false;
  for (int s = 0; s < 3; ++s) {
    int given = 0;
    for (int a = 0; a < 3; ++a) {
      l.axis_column[s][a] = columns.index(kAxisName[s][a]);
      given += l.axis_column[s][a] >= 0;
    }
    if (given != 0 && given != 3)
      return std::string(kSensorName[s]) + " needs all three axes or none (columns " +
             columns.describe() + ")";
    any = any || given == 3;
  }
  if (!any) return "no sensor columns (ax,ay,az / gx,gy,gz / mx,my,mz) in " + columns.describe();
  if (need_accel && l.axis_column[0][0] < 0)
    return "no accelerometer columns (ax,ay,az): one message is made per accelerometer reading "
           "(or give --assemble per-sample)";
  l.columns_needed = columns.needed();
  layout = l;
  return "";
}

FileImport::FileImport(FileImportOptions options, std::function<void(const imu_t&)> publish)
    : o_(std::move(options)), publish_(std::move(publish)), reader_(o_.read) {
  if (o_.rate_hz > 0)
    clock_ = table::RowClock(o_.start_utime.value_or(kRateDefaultStartUs), o_.rate_hz);
  else
    clock_ = table::RowClock(o_.start_utime, 0);
  if (o_.columns) {
    setup_error_ = columns_.set_from_list(*o_.columns, file_known_columns());
    if (setup_error_.empty())
      setup_error_ = file_layout_from(columns_, o_.rate_hz > 0, !o_.assembler.per_sample, layout_);
    if (!setup_error_.empty()) setup_error_ = "--columns: " + setup_error_;
    columns_from_ = "(from --columns)";
    laid_out_ = setup_error_.empty();
  }
  if (o_.time_unit) {
    unit_ = *o_.time_unit;
    unit_from_ = "--time-unit";
  }
}

bool FileImport::set_up_layout() {
  const std::vector<std::string_view> header = reader_.header_views();
  if (!header.empty()) {
    columns_.set_from_header(header, file_known_columns());
    const std::string why =
        file_layout_from(columns_, o_.rate_hz > 0, !o_.assembler.per_sample, layout_);
    if (!why.empty()) {
      std::string names;
      for (std::string_view h : header) names += (names.empty() ? "" : ",") + std::string(h);
      fatal_ = o_.input + ": the header '" + table::excerpt(names, 80) +
               "' names no usable columns (" + why + "); give --columns, e.g. --columns " +
               std::string(kDefaultFileColumns);
      return false;
    }
    columns_from_ = "(from the header)";
    return true;
  }
  std::string list(kDefaultFileColumns);
  if (o_.rate_hz > 0) list = list.substr(2);  // no time column
  columns_.set_from_list(list, file_known_columns());
  file_layout_from(columns_, o_.rate_hz > 0, !o_.assembler.per_sample, layout_);
  columns_from_ = "(the default: no header and no --columns)";
  return true;
}

void FileImport::feed(std::string_view line) {
  if (!setup_error_.empty()) return;
  const table::TableReader::Kind kind = reader_.feed(line);
  tally_.note(reader_, kind, line);
  if (kind != table::TableReader::Kind::kData) return;
  if (!fatal_.empty()) {
    tally_.reject(reader_.line_number(), line, "no column mapping");
    return;
  }
  if (!laid_out_) {
    laid_out_ = true;
    if (!set_up_layout()) {
      tally_.reject(reader_.line_number(), line, "no column mapping");
      return;
    }
  }
  row(reader_.fields(), line);
}

void FileImport::row(const std::vector<std::string_view>& f, std::string_view line) {
  const bool rate = o_.rate_hz > 0;
  // A --rate file's clock counts every data row, good or bad, so a lost row keeps its slot.
  std::optional<int64_t> rate_utime;
  if (rate) rate_utime = clock_.next(std::nullopt);
  auto reject = [&](const std::string& why) { tally_.reject(reader_.line_number(), line, why); };
  if (f.size() < static_cast<size_t>(layout_.columns_needed)) {
    reject(std::to_string(f.size()) + " fields, expected at least " +
           std::to_string(layout_.columns_needed) + " (" + columns_.describe() + ")");
    return;
  }
  int64_t utime = 0, device_us = 0;
  if (rate) {
    if (!rate_utime) {
      reject("beyond the time a --rate file can reach");
      return;
    }
    utime = *rate_utime;
    device_us = utime - o_.start_utime.value_or(kRateDefaultStartUs);
  } else {
    const std::string_view tf = f[static_cast<size_t>(layout_.time_column)];
    if (unit_from_.empty()) {
      // The unit of an epoch time of this magnitude; else seconds (said on stderr).
      double v = 0;
      if (table::parse_number(tf, v)) {
        if (const auto u = table::guess_epoch_unit(v)) {
          unit_ = *u;
          unit_from_ = "guessed from the first time's magnitude";
        } else if (std::fabs(v) >= 1e10) {
          // Not an epoch time in any unit, and over 300 years as seconds since boot: the unit
          // must be given.
          reject("time " + quoted(tf) + " is not a time in s");
          return;
        } else {
          unit_from_ = "not an epoch time in any unit: the default; give --time-unit";
        }
      }
    }
    int64_t t_us = 0;
    if (!table::parse_time_us(tf, unit_, t_us)) {
      reject("time " + quoted(tf) + " is not a time in " + table::time_unit_name(unit_));
      return;
    }
    const std::optional<int64_t> u = clock_.next(t_us);
    if (!u) {
      reject("time " + quoted(tf) + " cannot be placed");
      return;
    }
    utime = *u;
    device_us = t_us;
    if (clock_.since_boot() && warnings_.empty())
      warnings_.push_back("the times are before 2001 (time since boot or since the start?): " +
                          std::string("kept as they are; give --file-start to place them"));
  }
  SensorSample samples[3];
  int count = 0;
  for (int s = 0; s < 3; ++s) {
    const auto& cols = layout_.axis_column[static_cast<size_t>(s)];
    if (cols[0] < 0) continue;
    const int empty = f[static_cast<size_t>(cols[0])].empty() +
                      f[static_cast<size_t>(cols[1])].empty() +
                      f[static_cast<size_t>(cols[2])].empty();
    if (empty == 3) continue;  // no reading of this sensor in this row
    SensorSample& out = samples[count];
    out.kind = static_cast<SensorKind>(s);
    out.device_us = device_us;
    for (size_t a = 0; a < 3; ++a) {
      const std::string_view field = f[static_cast<size_t>(cols[a])];
      double v = 0;
      if (!table::parse_number(field, v)) {
        reject(std::string(kSensorName[s]) + " " + static_cast<char>('x' + a) + " " +
               quoted(field) + " is not a number");
        return;
      }
      out.xyz[a] = v * scale_of(s, o_.units);
    }
    ++count;
  }
  ++tally_.rows;
  if (count == 0) return;
  if (!streams_) {
    PhoneStreamsConfig c;
    c.source = o_.source;
    c.assembler = o_.assembler;
    c.fixed_offset_us = utime - device_us;
    streams_ = std::make_unique<PhoneStreams>(c, [this](const imu_t& m) {
      if (tally_.messages++ == 0) first_utime_ = m.utime;
      last_utime_ = m.utime;
      publish_(m);
    });
  }
  batch_.assign(samples, samples + count);
  dropped_ += streams_->on_batch(o_.device_id, 0, batch_).dropped;
}

std::string FileImport::finish() {
  if (!setup_error_.empty()) return setup_error_;
  if (!fatal_.empty()) return fatal_;
  table::ImportExpectation e;
  e.input = o_.input;
  e.columns = columns_.empty() ? std::string(kDefaultFileColumns) : columns_.describe();
  if (reader_.separator_known())
    e.separator = reader_.separator();
  else
    e.separator = o_.read.separator;
  e.separator_given = o_.read.separator.has_value();
  e.time_needed = o_.rate_hz <= 0;
  std::string v = table::import_verdict(tally_, e);
  if (v.empty() && tally_.messages == 0 && dropped_ > 0)
    v = o_.input + ": 0 messages: all " + std::to_string(dropped_) +
        " readings were dropped (times not increasing, or not placeable: check --time-unit and "
        "--file-start)";
  return v;
}

std::string FileImport::describe() const {
  std::vector<std::string> parts;
  if (reader_.separator_known())
    parts.push_back(std::string(table::separator_name(reader_.separator())) + "-separated" +
                    (o_.read.separator ? " (--separator)" : " (detected)"));
  if (!columns_.empty()) parts.push_back("columns " + columns_.describe() + " " + columns_from_);
  if (o_.rate_hz > 0) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%g", o_.rate_hz);
    parts.push_back(std::string("no time column: rows at ") + buf + " Hz" +
                    (o_.start_utime ? "" : " from 1 s after the Unix epoch (no --file-start)"));
  } else if (!unit_from_.empty()) {
    parts.push_back(std::string("times in ") + table::time_unit_name(unit_) + " (" + unit_from_ +
                    ")");
  }
  if (tally_.lines == 0) parts.push_back("empty: no line");
  std::string out;
  for (const std::string& p : parts) out += (out.empty() ? "" : ", ") + p;
  return out;
}

}  // namespace ips::phone_imu
