#include "drivers/phone_imu/csv_row.hpp"

#include <charconv>
#include <cmath>
#include <limits>
#include <system_error>

#include "core/device_text.hpp"

namespace ips::phone_imu {

namespace {

constexpr double kMaxUs = 4e18;

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r'))
    s.remove_suffix(1);
  return s;
}

// Splits on `sep` into at most kMaxRowFields views; false when there are more.
bool split(std::string_view row, char sep, std::vector<std::string_view>& out) {
  out.clear();
  size_t start = 0;
  for (;;) {
    const size_t end = row.find(sep, start);
    if (out.size() == kMaxRowFields) return false;
    out.push_back(trim(row.substr(start, end == std::string_view::npos ? row.size() - start
                                                                       : end - start)));
    if (end == std::string_view::npos) return true;
    start = end + 1;
  }
}

int64_t us_per_unit(TimeUnit u) {
  switch (u) {
    case TimeUnit::kS:
      return 1'000'000;
    case TimeUnit::kMs:
      return 1'000;
    case TimeUnit::kUs:
    case TimeUnit::kNs:
      return 1;
  }
  return 1;
}

double scale_of(SensorKind k, const UnitScales& u) {
  switch (k) {
    case SensorKind::kAccel:
      return u.accel;
    case SensorKind::kGyro:
      return u.gyro;
    case SensorKind::kMag:
      return u.mag;
  }
  return 1.0;
}

const char* kSensorName[] = {"accelerometer", "gyroscope", "magnetometer"};

// Values each IMU+GPS-Stream sensor id carries (the app's source listing, see the header).
int tagged_value_count(int64_t id) {
  switch (id) {
    case 3:
    case 4:
    case 5:
    case 1:
    case 81:
    case 82:
    case 83:
    case 84:
      return 3;
    case 85:
    case 86:
      return 1;
    default:
      return -1;
  }
}

bool read_triple(const std::vector<std::string_view>& f, size_t at, SensorKind kind,
                 const UnitScales& units, std::array<double, 3>& xyz, std::string& reason) {
  for (size_t a = 0; a < 3; ++a) {
    double v = 0;
    if (!parse_number(f[at + a], v)) {
      reason = std::string(kSensorName[static_cast<int>(kind)]) + " " +
               static_cast<char>('x' + a) + " " + quoted_field(f[at + a]) + " is not a number";
      return false;
    }
    xyz[a] = v * scale_of(kind, units);
  }
  return true;
}

}  // namespace

std::optional<TimeUnit> time_unit_from_name(std::string_view name) {
  if (name == "s") return TimeUnit::kS;
  if (name == "ms") return TimeUnit::kMs;
  if (name == "us") return TimeUnit::kUs;
  if (name == "ns") return TimeUnit::kNs;
  return std::nullopt;
}

bool accel_scale_from_name(std::string_view name, double& scale) {
  if (name == "m/s2") scale = 1.0;
  else if (name == "g") scale = kStandardGravity;
  else return false;
  return true;
}
bool gyro_scale_from_name(std::string_view name, double& scale) {
  if (name == "rad/s") scale = 1.0;
  else if (name == "deg/s") scale = kRadPerDeg;
  else return false;
  return true;
}
bool mag_scale_from_name(std::string_view name, double& scale) {
  if (name == "uT") scale = 1.0;
  else if (name == "mG") scale = 0.1;
  else return false;
  return true;
}

bool parse_number(std::string_view field, double& value) {
  field = trim(field);
  if (field.empty() || field.size() > 64) return false;
  if (field.front() == '+') field.remove_prefix(1);
  bool digit = false;
  for (char c : field) {
    if (c >= '0' && c <= '9') digit = true;
    else if (!(c == '.' || c == '-' || c == '+' || c == 'e' || c == 'E')) return false;
  }
  if (!digit) return false;
  double v = 0;
  const auto [end, ec] = std::from_chars(field.data(), field.data() + field.size(), v);
  if (ec != std::errc() || end != field.data() + field.size() || !std::isfinite(v)) return false;
  value = v;
  return true;
}

bool parse_time_us(std::string_view field, TimeUnit unit, int64_t& us) {
  field = trim(field);
  int64_t whole = 0;
  if (parse_integer(field, whole)) {  // exact for ns epoch times, beyond a double's 53 bits
    if (whole < 0) return false;
    if (unit == TimeUnit::kNs) {
      us = whole / 1000 + (whole % 1000 >= 500 ? 1 : 0);
      return true;
    }
    const int64_t k = us_per_unit(unit);
    if (static_cast<double>(whole) * static_cast<double>(k) >= kMaxUs) return false;
    us = whole * k;
    return true;
  }
  double v = 0;
  if (!parse_number(field, v) || v < 0) return false;
  const double x = unit == TimeUnit::kNs ? v / 1000.0 : v * static_cast<double>(us_per_unit(unit));
  if (!(x < kMaxUs)) return false;
  us = static_cast<int64_t>(std::llround(x));
  return true;
}

std::string parse_column_mapping(std::string_view spec, RowFormat& format) {
  RowFormat f = format;
  f.axis_column = {{{-1, -1, -1}, {-1, -1, -1}, {-1, -1, -1}}};
  if (spec == "tagged") {
    f.tagged = true;
    format = f;
    return "";
  }
  f.tagged = false;
  f.time_column = -1;
  std::vector<std::string_view> names;
  if (!split(spec, ',', names)) return "too many columns";
  static constexpr std::string_view kAxes[3][3] = {
      {"ax", "ay", "az"}, {"gx", "gy", "gz"}, {"mx", "my", "mz"}};
  int last = -1;
  for (size_t i = 0; i < names.size(); ++i) {
    const std::string_view n = names[i];
    const int col = static_cast<int>(i);
    bool known = false;
    if (n == "-") {
      known = true;
    } else if (n == "t") {
      if (f.time_column >= 0) return "t is given twice";
      f.time_column = col;
      last = col;
      known = true;
    }
    for (int s = 0; s < 3 && !known; ++s)
      for (int a = 0; a < 3; ++a)
        if (n == kAxes[s][a]) {
          if (f.axis_column[s][a] >= 0) return std::string(n) + " is given twice";
          f.axis_column[s][a] = col;
          last = col;
          known = true;
          break;
        }
    if (!known)
      return "unknown column " + quoted_field(n) +
             " (expected t, ax, ay, az, gx, gy, gz, mx, my, mz, - or the word tagged)";
  }
  if (f.time_column < 0) return "no t (time) column";
  bool any = false;
  for (int s = 0; s < 3; ++s) {
    const int given = (f.axis_column[s][0] >= 0) + (f.axis_column[s][1] >= 0) +
                      (f.axis_column[s][2] >= 0);
    if (given != 0 && given != 3)
      return std::string(kSensorName[s]) + " needs all three axes or none";
    any = any || given == 3;
  }
  if (!any) return "no sensor columns (ax,ay,az / gx,gy,gz / mx,my,mz)";
  f.columns_needed = last + 1;
  format = f;
  return "";
}

RowParse parse_row(std::string_view row, const RowFormat& format) {
  RowParse r;
  thread_local std::vector<std::string_view> f;
  if (!split(row, format.separator, f)) {
    r.reason = "more than " + std::to_string(kMaxRowFields) + " fields";
    return r;
  }
  const size_t time_col = format.tagged ? 0 : static_cast<size_t>(format.time_column);
  if (!format.tagged && f.size() < static_cast<size_t>(format.columns_needed)) {
    r.reason = std::to_string(f.size()) + " fields, expected at least " +
               std::to_string(format.columns_needed);
    return r;
  }
  if (!parse_time_us(f[time_col], format.time_unit, r.device_us)) {
    r.reason = "time " + quoted_field(f[time_col]) + " is not a time >= 0";
    return r;
  }
  if (format.tagged) {
    bool seen[3] = {false, false, false};
    size_t i = 1;
    if (f.size() == 1) {
      r.reason = "a time and no sensor";
      return r;
    }
    while (i < f.size()) {
      int64_t id = 0;
      if (!parse_integer(f[i], id)) {
        r.reason = "sensor id " + quoted_field(f[i]) + " is not an integer";
        return r;
      }
      const int n = tagged_value_count(id);
      if (n < 0) {
        r.reason = "unknown sensor id " + std::to_string(id);
        return r;
      }
      if (i + 1 + static_cast<size_t>(n) > f.size()) {
        r.reason = "sensor " + std::to_string(id) + " cut short: " +
                   std::to_string(f.size() - i - 1) + " of " + std::to_string(n) + " values";
        return r;
      }
      if (id >= 3 && id <= 5) {
        const auto kind = static_cast<SensorKind>(id - 3);
        if (seen[id - 3]) {
          r.reason = "sensor " + std::to_string(id) + " twice in one row";
          return r;
        }
        seen[id - 3] = true;
        SensorSample& s = r.samples[static_cast<size_t>(r.count)];
        if (!read_triple(f, i + 1, kind, format.units, s.xyz, r.reason)) return r;
        s.kind = kind;
        s.device_us = r.device_us;
        ++r.count;
      } else {
        for (int k = 0; k < n; ++k) {
          double v = 0;
          if (!parse_number(f[i + 1 + static_cast<size_t>(k)], v)) {
            r.reason = "sensor " + std::to_string(id) + " value " +
                       quoted_field(f[i + 1 + static_cast<size_t>(k)]) + " is not a number";
            return r;
          }
        }
      }
      i += 1 + static_cast<size_t>(n);
    }
    r.ok = true;
    return r;
  }
  for (int s = 0; s < 3; ++s) {
    const auto& cols = format.axis_column[s];
    if (cols[0] < 0) continue;
    const int empty = f[static_cast<size_t>(cols[0])].empty() +
                      f[static_cast<size_t>(cols[1])].empty() +
                      f[static_cast<size_t>(cols[2])].empty();
    if (empty == 3) continue;  // this sensor has no reading in this row
    SensorSample& out = r.samples[static_cast<size_t>(r.count)];
    out.kind = static_cast<SensorKind>(s);
    out.device_us = r.device_us;
    for (size_t a = 0; a < 3; ++a) {
      const std::string_view field = f[static_cast<size_t>(cols[a])];
      double v = 0;
      if (!parse_number(field, v)) {
        r.reason = std::string(kSensorName[s]) + " " + static_cast<char>('x' + a) + " " +
                   quoted_field(field) + " is not a number";
        return r;
      }
      out.xyz[a] = v * scale_of(out.kind, format.units);
    }
    ++r.count;
  }
  r.ok = true;
  return r;
}

}  // namespace ips::phone_imu
