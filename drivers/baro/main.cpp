// ips-baro: barometers -> baro_t on BARO. Linux IIO devices (BMP280, BMP388/390, BME280, LPS22,
// ...) read through sysfs at --rate-hz, and microcontrollers printing "P <Pa> T <degC> [H <%>]"
// lines on serial ports, each sample stamped with the host time it was read; several sensors in
// one process. Reference stations carry their known height. A sensor that goes away is reported
// in HEALTH while the others keep publishing, and is picked up again when it returns.
// Details: docs/hardware/barometer.md.
#include <spdlog/spdlog.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/channels.hpp"
#include "core/cli.hpp"
#include "core/error_limiter.hpp"
#include "core/import_output.hpp"
#include "core/line_buffer.hpp"
#include "core/node.hpp"
#include "core/serial_port.hpp"
#include "core/site.hpp"
#include "core/text_escape.hpp"
#include "drivers/baro/baro_file.hpp"
#include "drivers/baro/baro_line_parser.hpp"
#include "drivers/baro/iio_sensor.hpp"
#include "drivers/baro/sensor_spec.hpp"

namespace {

using namespace ips::baro;

constexpr const char* kProgram = "ips-baro";
// A sample line is about 30 bytes; a longer one is garbage.
constexpr size_t kMaxLineBytes = 256;

double monotonic_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

struct Settings {
  std::vector<SensorSpec> sensors;
  std::vector<ReferenceSpec> references;
  std::string sysfs_root = kDefaultSysfsRoot;
  double rate_hz = 10.0;
  int oversampling = 0;
  ips::SerialLinkOptions serial;
};

struct IioStation {
  std::unique_ptr<IioSensor> sensor;
  std::optional<double> height_m;
};

struct SerialStation {
  SensorSpec spec;
  std::optional<double> height_m;
  ips::LineBuffer lines{kMaxLineBytes};
  int64_t overlong_reported = 0;
  std::unique_ptr<ips::SerialLink> link;
};

std::optional<double> height_of(const std::map<std::string, double>& heights,
                                const std::string& id) {
  const auto it = heights.find(id);
  return it == heights.end() ? std::nullopt : std::optional<double>(it->second);
}

// Finds and opens every IIO device; false (after printing the start-up error) when one cannot
// be used or two names lead to the same device.
bool start_iio(const Settings& s, const std::map<std::string, double>& heights,
               std::vector<IioStation>& out) {
  std::map<std::string, std::string> ids_by_dir;
  for (const SensorSpec& spec : s.sensors) {
    if (spec.kind == SensorSpec::Kind::kSerial) continue;
    IioSensorConfig c;
    c.id = spec.id;
    c.root = s.sysfs_root;
    (spec.kind == SensorSpec::Kind::kIioByName ? c.name : c.path) = spec.target;
    c.oversampling = s.oversampling;
    c.reopen_s = s.serial.reopen_s;
    auto sensor = std::make_unique<IioSensor>(c);
    std::string error;
    if (!sensor->start(error)) {
      ips::print_fatal(kProgram,
                       "--iio " + spec.id + "=" + ips::printable(spec.target) + ": " + error);
      return false;
    }
    const IioDevice& d = sensor->device();
    if (const auto [it, added] = ids_by_dir.emplace(d.real_dir(), spec.id); !added) {
      ips::print_fatal(kProgram, "--iio " + it->second + " and --iio " + spec.id +
                                     " are the same device " + ips::printable(d.dir()));
      return false;
    }
    out.push_back({std::move(sensor), height_of(heights, spec.id)});
  }
  for (const IioStation& st : out) {  // only once every device is known good: errors are 1 line
    const IioDevice& d = st.sensor->device();
    spdlog::info("{}: IIO device {}: {} '{}' by {}: pressure from in_pressure_{}{}{}", kProgram,
                 st.sensor->config().id, ips::printable(d.dir()), ips::printable(d.name()),
                 st.sensor->selector(), d.pressure_from_raw() ? "raw" : "input",
                 d.has_temperature() ? ", temperature" : ", no temperature",
                 d.has_humidity() ? ", humidity" : "");
  }
  return true;
}

int run(const ips::CommonOptions& opts, Settings& s) {
  std::optional<ips::Site> site;
  if (!opts.site_path.empty()) site = ips::load_site_file(opts.site_path);
  std::map<std::string, double> heights;
  std::vector<std::string> warnings;
  std::string error;
  if (!reference_heights(s.references, s.sensors, site ? &*site : nullptr, heights, warnings,
                         error)) {
    ips::print_fatal(kProgram, error);
    return 2;
  }
  std::vector<IioStation> iio;
  if (!start_iio(s, heights, iio)) return 2;
  for (const std::string& w : warnings) spdlog::warn("{}: {}", kProgram, w);

  ips::Node node(kProgram, opts);
  const std::string channel = opts.channel(ips::channel::kBaro);
  std::vector<std::unique_ptr<SerialStation>> serial;
  // Bad samples: counted each, reported at most once a second per sensor (a sensor that stays
  // broken at 10 Hz must not fill the log), the next report saying how many were held back.
  ips::ErrorLimiter bad_reports;
  auto bad_sample = [&](const std::string& sensor_id, const std::string& text) {
    ++node.counters().parse_errors;
    if (auto line = bad_reports.admit(sensor_id, text, ips::wall_utime_now()))
      node.report_error(*line);
  };
  // HEALTH is degraded while any sensor is away, and ok again once all are back: each away
  // sensor is a lasting error of the node (SerialLink's for serial ones, keyed by the path).

  for (const SensorSpec& spec : s.sensors) {
    if (spec.kind != SensorSpec::Kind::kSerial) continue;
    auto station = std::make_unique<SerialStation>();
    SerialStation& st = *station;
    st.spec = spec;
    st.height_m = height_of(heights, spec.id);
    const std::string source = std::string(kProgram) + ":" + spec.target;
    auto on_line = [&node, &st, &channel, &bad_sample, source](std::string_view line,
                                                               ips::utime_t utime) {
      ++node.counters().msgs_in;
      const BaroLineResult r = parse_baro_line(line);
      if (r.kind == BaroLineResult::Kind::kSample) {
        node.publish(channel, to_message(r.reading, utime, source, st.spec.id, st.height_m));
      } else if (r.kind == BaroLineResult::Kind::kComment) {
        spdlog::debug("{}: {}: {}", kProgram, st.spec.id, ips::printable(line));
      } else {
        bad_sample(st.spec.id, "skipped line from " + st.spec.id + " (" +
                                   ips::printable(st.spec.target) + "): " + r.reason);
      }
    };
    ips::SerialLinkOptions link_options = s.serial;
    link_options.path = spec.target;
    st.link = std::make_unique<ips::SerialLink>(
        node, link_options,
        ips::SerialLink::Callbacks{
            // A partial line belongs to the device's previous life.
            .on_open = [&st] { st.lines.reset(); },
            .on_bytes =
                [&st, &bad_sample, on_line](std::string_view bytes, ips::utime_t utime) {
                  st.lines.feed(bytes, [&](std::string_view line) { on_line(line, utime); });
                  for (; st.overlong_reported < st.lines.overlong_lines(); ++st.overlong_reported)
                    bad_sample(st.spec.id, "skipped a line longer than " +
                                               std::to_string(kMaxLineBytes) + " bytes from " +
                                               st.spec.id);
                },
            .on_close = {},
        });
    serial.push_back(std::move(station));
  }
  for (auto& st : serial)
    if (!st->link->start(error)) {
      ips::print_fatal(kProgram, "--serial " + st->spec.id + "=" + ips::printable(error));
      return 2;
    }

  if (!iio.empty()) {
    node.add_timer(1.0 / s.rate_hz, [&] {
      for (IioStation& st : iio) {
        const IioSensor::Poll p = st.sensor->poll(monotonic_s());
        const ips::utime_t utime = ips::wall_utime_now();
        if (p.reopened)
          spdlog::info("{}: IIO device {} is back at {}", kProgram, st.sensor->config().id,
                       ips::printable(st.sensor->device().dir()));
        if (!p.reopen_problem.empty()) node.report_error(p.reopen_problem);
        switch (p.kind) {
          case IioSensor::Poll::Kind::kSample:
            ++node.counters().msgs_in;
            node.publish(channel,
                         to_message(p.reading, utime,
                                    std::string(kProgram) + ":" + st.sensor->device().dir(),
                                    st.sensor->config().id, st.height_m));
            break;
          case IioSensor::Poll::Kind::kBad:
            ++node.counters().msgs_in;
            bad_sample(st.sensor->config().id, p.text);
            break;
          case IioSensor::Poll::Kind::kGone:
          case IioSensor::Poll::Kind::kMissing:
            node.report_lasting_error("iio:" + st.sensor->config().id, p.text);
            break;
          case IioSensor::Poll::Kind::kNothing:
            break;
        }
        if (st.sensor->present()) node.end_lasting_error("iio:" + st.sensor->config().id);
      }
    });
  }
  const int status = node.run();
  for (auto& st : serial) st->link.reset();  // before the node
  return status;
}


// --- --file: recorded logs --------------------------------------------------------------------

struct FileSettings {
  std::vector<SensorSpec> files;  // kind kFile: id = the file's own sensor, target = the path
  std::string columns, units, separator, header = "auto", time_unit, file_start, file_end;
  std::string out, start_reference;
  double rate_hz = 0, speed = 0;
};

// Unix time in s or ISO-8601 -> us; false when neither.
bool parse_start_time(const std::string& text, int64_t& us) {
  if (ips::table::parse_iso8601_us(text, us)) return true;
  double s = 0;
  if (!ips::table::parse_number(text, s) || !(std::fabs(s) < 4e12)) return false;
  us = static_cast<int64_t>(std::llround(s * 1e6));
  return true;
}

bool read_whole(const std::string& path, std::string& text, std::string& error) {
  std::ostringstream buf;
  if (path == "-") {
    buf << std::cin.rdbuf();
    text = buf.str();
    return true;
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    error = "cannot read '" + ips::printable(path) + "'";
    return false;
  }
  buf << in.rdbuf();
  if (in.bad()) {
    error = "cannot read '" + ips::printable(path) + "'";
    return false;
  }
  text = buf.str();
  return true;
}

// How many metres one Pa is at this pressure and temperature (the hypsometric equation's slope).
double metres_per_pa(double p_pa, double t_c) {
  const double t_k = (std::isnan(t_c) ? 15.0 : t_c) + 273.15;
  return 287.05 * t_k / (9.80665 * p_pa);
}

std::string fixed(double v, int decimals) {
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

int run_files(const ips::CommonOptions& opts, const FileSettings& fs,
              const std::vector<ReferenceSpec>& references) {
  std::optional<ips::Site> site;
  if (!opts.site_path.empty()) site = ips::load_site_file(opts.site_path);
  auto usage = [](const std::string& what) {
    ips::print_fatal(kProgram, what);
    return 2;
  };
  FileOptions base;
  if (!fs.separator.empty()) {
    base.read.separator = ips::table::separator_from_name(fs.separator);
    if (!base.read.separator)
      return usage("--separator: expected , ; tab or space, got '" +
                   ips::printable(fs.separator) + "'");
  }
  if (fs.header == "none") base.read.header = ips::table::HeaderMode::kNone;
  else if (fs.header == "yes") base.read.header = ips::table::HeaderMode::kPresent;
  else if (fs.header != "auto") return usage("--header: expected auto, none or yes");
  int64_t t = 0;
  if (!fs.file_start.empty()) {
    if (!parse_start_time(fs.file_start, t))
      return usage("--file-start: '" + ips::printable(fs.file_start) +
                   "' is not a Unix time in s or an ISO-8601 date-time");
    base.start_utime = t;
  }
  if (!fs.file_end.empty()) {
    if (!parse_start_time(fs.file_end, t))
      return usage("--file-end: '" + ips::printable(fs.file_end) +
                   "' is not a Unix time in s or an ISO-8601 date-time");
    base.end_utime = t;
  }
  if (base.start_utime && base.end_utime && *base.end_utime <= *base.start_utime)
    return usage("--file-end is not after --file-start");
  base.rate_hz = fs.rate_hz;

  // Every file's layout first: a bad --columns is a usage error before anything is read.
  std::vector<FileOptions> per_file;
  std::vector<SensorSpec> sensors;
  std::string reason;
  for (const SensorSpec& f : fs.files) {
    FileOptions o = base;
    o.name = f.target == "-" ? "stdin" : f.target;
    if (!parse_file_layout(fs.columns, fs.units, f.id, o.layout, reason)) return usage(reason);
    if (!fs.time_unit.empty()) {
      o.layout.time_unit = ips::table::time_unit_from_name(fs.time_unit);
      if (!o.layout.time_unit)
        return usage("--time-unit: expected s, ms, us or ns, got '" +
                     ips::printable(fs.time_unit) + "'");
    }
    for (const std::string& id : o.layout.sensors) {
      for (const SensorSpec& s : sensors)
        if (s.id == id)
          return usage("sensor id " + id + " comes from two files: give each file its own " +
                       "sensor id (--file ID=FILE)");
      sensors.push_back({SensorSpec::Kind::kFile, id, f.target});
    }
    per_file.push_back(std::move(o));
  }
  std::map<std::string, double> heights;
  std::vector<std::string> warnings;
  if (!reference_heights(references, sensors, site ? &*site : nullptr, heights, warnings, reason))
    return usage(reason);
  std::string start_ref_id;
  if (!fs.start_reference.empty()) {
    bool known = false;
    for (const SensorSpec& s : sensors) known = known || s.id == fs.start_reference;
    if (!known)
      return usage("--start-reference " + ips::printable(fs.start_reference) +
                   ": no such sensor in the --columns");
    if (heights.count(fs.start_reference))
      return usage("--start-reference " + fs.start_reference + " is a --reference itself");
    start_ref_id = fs.start_reference + ".start";
    if (!valid_sensor_id(start_ref_id))
      return usage("--start-reference: the sensor id is too long for '" + start_ref_id + "'");
  }
  for (const std::string& w : warnings) spdlog::warn("{}: {}", kProgram, w);

  const std::string channel = opts.channel(ips::channel::kBaro);
  ips::ImportOutput output;
  int64_t start_ref_count = 0;
  for (size_t i = 0; i < per_file.size(); ++i) {
    const FileOptions& o = per_file[i];
    std::string text, error;
    if (!read_whole(fs.files[i].target, text, error)) return usage(error);
    const FileResult r = read_baro_file(text, o);
    if (!r.error.empty()) {
      ips::print_fatal(kProgram, r.error);
      return 1;
    }
    ips::table::ImportExpectation e;
    e.input = o.name;
    e.columns = o.layout.describe();
    e.separator = o.read.separator;
    e.separator_given = o.read.separator.has_value();
    e.time_needed = o.layout.has_time();
    std::string verdict = ips::table::import_verdict(r.tally, e);
    if (verdict.empty() && r.samples.empty())
      verdict = o.name + ": 0 samples from " + std::to_string(r.tally.lines) +
                " lines (an empty file?)";
    if (!verdict.empty() && verdict.find("; ", verdict.rfind(')')) == std::string::npos &&
        r.tally.first_bad_reason.find(" is outside ") != std::string::npos)
      verdict += "; check --units (e.g. 0.001hPa)";
    if (!verdict.empty()) {
      ips::print_fatal(kProgram, verdict);
      return 1;
    }
    const std::string source = std::string(kProgram) + ":file:" + o.name;
    // The start reference: the mean of its sensor's first second, held.
    std::optional<BaroReading> held;
    int start_sensor = -1;
    for (size_t k = 0; k < o.layout.sensors.size(); ++k)
      if (!start_ref_id.empty() && o.layout.sensors[k] == fs.start_reference)
        start_sensor = static_cast<int>(k);
    if (start_sensor >= 0) {
      double sp = 0, st = 0;
      int64_t n = 0, nt = 0, first = -1;
      for (const FileSample& s : r.samples) {
        if (s.sensor != start_sensor) continue;
        if (first < 0) first = s.utime;
        if (s.utime > first + 1'000'000) break;
        sp += s.reading.pressure_pa, ++n;
        if (!std::isnan(s.reading.temperature_c)) st += s.reading.temperature_c, ++nt;
      }
      if (n > 0) {
        BaroReading h;
        h.pressure_pa = sp / static_cast<double>(n);
        if (nt > 0) h.temperature_c = st / static_cast<double>(nt);
        held = h;
        std::fprintf(stderr,
                     "%s: --start-reference: %s is a reference station at 0 m holding %s's mean "
                     "of its first second (%lld samples): %s Pa, %s degC\n",
                     kProgram, start_ref_id.c_str(), fs.start_reference.c_str(),
                     static_cast<long long>(n), fixed(h.pressure_pa, 2).c_str(),
                     fixed(h.temperature_c, 2).c_str());
      }
    }
    for (const FileSample& s : r.samples) {
      const std::string& id = o.layout.sensors[static_cast<size_t>(s.sensor)];
      if (held && s.sensor == start_sensor) {
        output.add(channel, to_message(*held, s.utime, std::string(kProgram) + ":start-reference",
                                       start_ref_id, 0.0));
        ++start_ref_count;
      }
      output.add(channel, to_message(s.reading, s.utime, source, id, height_of(heights, id)));
    }
    // The summary: one line for the file, one per sensor.
    const ips::table::ImportTally& tl = r.tally;
    const double span_s = r.samples.empty() ? 0.0
                          : static_cast<double>(r.samples.back().utime - r.samples.front().utime) * 1e-6;
    std::string line = o.name + ": " + std::to_string(tl.lines) + " lines, " +
                       std::to_string(tl.rows + tl.bad) + " rows, " + std::to_string(tl.rows) +
                       " used, " + std::to_string(tl.bad) + " rejected";
    if (tl.bad > 0)
      line += " (first: line " + std::to_string(tl.first_bad_line) + ": " + tl.first_bad_reason + ")";
    line += "; " + std::to_string(r.samples.size()) + " samples over " + fixed(span_s, 1) + " s; " +
            r.time_note;
    std::fprintf(stderr, "%s: %s\n", kProgram, line.c_str());
    for (size_t k = 0; k < o.layout.sensors.size(); ++k) {
      const SensorTally& st = r.sensors[k];
      std::string sl = o.name + ": sensor " + o.layout.sensors[k] + ": " +
                       std::to_string(st.samples) + " samples";
      if (st.samples > 0) {
        const double t_c = st.n_t > 0 ? st.sum_t / static_cast<double>(st.n_t) : kNaN;
        const double sd = st.std_p();
        sl += ", pressure mean " + fixed(st.mean_p(), 2) + " Pa";
        if (!std::isnan(sd))
          sl += ", std " + fixed(sd, 2) + " Pa (" + fixed(sd * metres_per_pa(st.mean_p(), t_c), 3) +
                " m of height per sample)";
      }
      sl += ", " + std::to_string(st.rejected) + " rejected";
      if (st.rejected > 0)
        sl += " (first: line " + std::to_string(st.first_rejected_line) + ": " + st.first_reason + ")";
      std::fprintf(stderr, "%s: %s\n", kProgram, sl.c_str());
    }
  }
  if (!fs.out.empty()) {
    if (const std::string err = output.write_log(fs.out); !err.empty()) {
      ips::print_fatal(kProgram, err);
      return 2;
    }
    std::fprintf(stderr, "%s: wrote %lld messages on %s to %s\n", kProgram,
                 static_cast<long long>(output.size()), channel.c_str(),
                 ips::printable(fs.out).c_str());
    return 0;
  }
  ips::Node node(kProgram, opts);
  if (!output.publish(node, fs.speed)) return 0;  // stopped by a signal
  std::fprintf(stderr, "%s: published %lld messages on %s\n", kProgram,
               static_cast<long long>(output.size()), channel.c_str());
  (void)start_ref_count;
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "ips-baro: barometers, published as baro_t on BARO with the host time each sample was "
      "read. --iio: Linux IIO devices (BMP280, BMP388/390, BME280, LPS22, ...) read through "
      "sysfs at --rate-hz (in_pressure_input kPa, in_temp_input milli degC, "
      "in_humidityrelative_input milli %, or _raw with _scale and _offset); --serial: "
      "microcontrollers printing lines 'P <Pa> T <degC> [H <%>]'. Several sensors per process. "
      "--reference marks a fixed reference station with its known height. Samples outside "
      "30..125 kPa, -40..85 degC or 0..100 % are counted and skipped. A sensor that goes away "
      "is reported in HEALTH while the others keep publishing, and picked up again when it "
      "returns. Details: docs/hardware/barometer.md.",
      kProgram};
  ips::CommonOptions opts;
  ips::add_common_options(app, opts, {.lcm = true, .site = false, .channels = true});
  app.add_option("--site", opts.site_path,
                 "site file (YAML): a --reference without =HEIGHT_M takes the z of its "
                 "baro_stations entry")
      ->type_name("FILE");
  Settings s;
  std::vector<std::string> iio_specs, serial_specs, reference_specs;
  app.add_option("--iio", iio_specs,
                 "an IIO barometer and the sensor id it is published as: by its name (the "
                 "device's `name` file, e.g. T1=bmp280; must be unique) or by its directory "
                 "(B1=/sys/bus/iio/devices/iio:device1, or B1=iio:device1, or the I2C device "
                 "holding it, B1=/sys/bus/i2c/devices/1-0077); repeatable")
      ->type_name("ID=NAME|PATH");
  app.add_option("--serial", serial_specs,
                 "a serial line sensor (P <Pa> T <degC> [H <%>] lines) and its sensor id, e.g. "
                 "T2=/dev/ttyUSB0; repeatable")
      ->type_name("ID=PATH");
  auto* o_baud =
      app.add_option("--baud", s.serial.baud, "--serial: line speed, 8N1")->capture_default_str();
  app.add_option("--reopen-s", s.serial.reopen_s,
                 "retry period while a sensor is missing or gone (IIO: re-scan by name), s")
      ->capture_default_str()
      ->check(CLI::Range(0.05, 3600.0));
  auto* o_rate = app.add_option("--rate-hz", s.rate_hz, "--iio: samples per second per device")
                     ->capture_default_str()
                     ->check(CLI::Range(0.1, 100.0));
  auto* o_osr = app.add_option("--oversampling", s.oversampling,
                               "--iio: write this to each device's in_pressure_oversampling_ratio "
                               "at every open (e.g. 16; the kernel driver says which it takes)")
                    ->check(CLI::Range(1, 128));
  auto* o_root = app.add_option("--sysfs-root", s.sysfs_root,
                                "--iio: where the iio:deviceN directories are (tests: a fake tree)")
                     ->capture_default_str()
                     ->type_name("DIR");
  app.add_option("--reference", reference_specs,
                 "sensor ID is a fixed reference station: is_reference, and known_height_m = "
                 "HEIGHT_M above the site origin, or the z of the --site's baro_stations entry "
                 "ID; repeatable")
      ->type_name("ID[=HEIGHT_M]");
  FileSettings fs;
  std::vector<std::string> file_specs;
  std::string device = "T1";
  app.add_option("--file", file_specs,
                 "a recorded log instead of devices: F, '-' for stdin, or ID=F (the file's "
                 "sensor id; else --device); repeatable (one file per sensor). Without "
                 "--columns: 'P <Pa> T <degC> [H <%>]' lines; with it: delimited text. Read as "
                 "fast as possible, times from the file only")
      ->type_name("[ID=]F|-");
  app.add_option("--device", device, "--file: the file's own sensor id (columns p, t, h)")
      ->capture_default_str()
      ->type_name("ID");
  app.add_option("--columns", fs.columns,
                 "--file: the columns by position: p, t, h (the file's sensor: pressure, "
                 "temperature, humidity), NAME or NAME.p / NAME.t / NAME.h (another sensor NAME "
                 "in the same file), time, '-' (skipped); e.g. mpl,p,t")
      ->type_name("LIST");
  app.add_option("--units", fs.units,
                 "--file: one unit per --columns entry, in the same order ('-': the default Pa, "
                 "degC, %, guessed time unit); e.g. 0.001hPa,0.001hPa,0.001degC")
      ->type_name("LIST");
  app.add_option("--separator", fs.separator,
                 "--file: the column separator (default: detected from the first data line)")
      ->type_name(", | ; | tab | space");
  app.add_option("--header", fs.header, "--file: a column header line: auto, none or yes")
      ->capture_default_str();
  app.add_option("--time-unit", fs.time_unit,
                 "--file: the time column's unit (default: guessed from the magnitude of epoch "
                 "times, else s)")
      ->type_name("s|ms|us|ns");
  app.add_option("--file-start", fs.file_start,
                 "--file: the time of the first row (Unix s or ISO-8601; default: the terminal "
                 "banner's 'Date:' line)")
      ->type_name("T");
  app.add_option("--file-end", fs.file_end,
                 "--file: the time of the last row, when there is no time column and no --rate "
                 "(default: the 'Date:' line after the data)")
      ->type_name("T");
  app.add_option("--rate", fs.rate_hz,
                 "--file without a time column: row k at file-start + k/HZ (default: the rows "
                 "spread evenly from the start to the end date; the rate is printed)")
      ->check(CLI::Range(1e-6, 1e6))
      ->type_name("HZ");
  app.add_option("--out", fs.out, "--file: write an LCM log instead of publishing")
      ->type_name("LOG");
  app.add_option("--speed", fs.speed,
                 "--file without --out: publish paced by the file's times at this speed "
                 "(default: as fast as possible)")
      ->check(CLI::Range(0.0, 1e6))
      ->type_name("X");
  app.add_option("--start-reference", fs.start_reference,
                 "--file, for a recording with no reference station: also publish a reference "
                 "station ID.start at 0 m holding the mean of sensor ID's first second, so that "
                 "ips-altitude gives ID's height change since the start (no weather "
                 "correction: for short recordings only)")
      ->type_name("ID");
  int rc = 0;
  if (!ips::parse_command_line(app, opts, argc, argv, rc)) return rc;

  auto usage_error = [](const std::string& what) {
    ips::print_fatal(kProgram, what + " (see --help)");
    return 2;
  };
  if (!file_specs.empty()) {
    if (!iio_specs.empty() || !serial_specs.empty())
      return usage_error("--file replaces --iio and --serial");
    for (const auto* o : {o_rate, o_osr, o_root, o_baud})
      if (o->count() > 0) return usage_error(o->get_name() + " does not go with --file");
    if (!fs.out.empty() && fs.speed > 0)
      return usage_error("--speed paces publishing on the bus: it does not go with --out");
    std::string why;
    for (const std::string& text : file_specs) {
      SensorSpec spec{SensorSpec::Kind::kFile, device, text};
      const size_t eq = text.find('=');
      if (eq != std::string::npos && eq > 0 && valid_sensor_id(text.substr(0, eq))) {
        spec.id = text.substr(0, eq);
        spec.target = text.substr(eq + 1);
      } else if (file_specs.size() > 1) {
        return usage_error("--file " + ips::printable(text) +
                           ": with several files give each its sensor id (--file ID=F)");
      }
      if (spec.target.empty()) return usage_error("--file: no file name in '" + text + "'");
      fs.files.push_back(spec);
    }
    std::vector<ReferenceSpec> refs;
    for (const std::string& text : reference_specs) {
      ReferenceSpec r;
      if (!parse_reference_spec(text, r, why)) return usage_error("--reference: " + why);
      refs.push_back(r);
    }
    return ips::run_reporting_errors(kProgram, [&] { return run_files(opts, fs, refs); });
  }
  for (const std::string* v : {&fs.columns, &fs.units, &fs.separator, &fs.time_unit, &fs.file_start,
                               &fs.file_end, &fs.out, &fs.start_reference})
    if (!v->empty()) return usage_error("--columns, --units, --separator, --time-unit, "
                                        "--file-start, --file-end, --out and --start-reference go "
                                        "with --file");
  if (fs.rate_hz > 0 || fs.speed > 0) return usage_error("--rate and --speed go with --file");
  if (iio_specs.empty() && serial_specs.empty())
    return usage_error("give --iio and/or --serial (one per sensor), or --file");
  if (iio_specs.empty())
    for (const auto* o : {o_rate, o_osr, o_root})
      if (o->count() > 0) return usage_error(o->get_name() + " goes with --iio");
  if (serial_specs.empty() && o_baud->count() > 0) return usage_error("--baud goes with --serial");
  std::string reason;
  for (const std::string& text : iio_specs) {
    SensorSpec spec;
    if (!parse_iio_spec(text, spec, reason)) return usage_error("--iio: " + reason);
    s.sensors.push_back(spec);
  }
  for (const std::string& text : serial_specs) {
    SensorSpec spec;
    if (!parse_serial_spec(text, spec, reason)) return usage_error("--serial: " + reason);
    if (const std::string problem = ips::serial_path_problem(spec.target); !problem.empty())
      return usage_error("--serial " + spec.id + "=" + ips::printable(spec.target) + ": " +
                         problem);
    s.sensors.push_back(spec);
  }
  if (!check_sensors(s.sensors, reason)) return usage_error(reason);
  for (const std::string& text : reference_specs) {
    ReferenceSpec r;
    if (!parse_reference_spec(text, r, reason)) return usage_error("--reference: " + reason);
    s.references.push_back(r);
  }
  if (!serial_specs.empty() && !ips::serial_baud_supported(s.serial.baud))
    return usage_error("--baud: " + std::to_string(s.serial.baud) +
                       " is not a speed termios can set (e.g. 9600, 115200, 921600)");
  return ips::run_reporting_errors(kProgram, [&] { return run(opts, s); });
}
