// ips-baro: barometers -> baro_t on BARO. Linux IIO devices (BMP280, BMP388/390, BME280, LPS22,
// ...) read through sysfs at --rate-hz, and microcontrollers printing "P <Pa> T <degC> [H <%>]"
// lines on serial ports, each sample stamped with the host time it was read; several sensors in
// one process. Reference stations carry their known height. A sensor that goes away is reported
// in HEALTH while the others keep publishing, and is picked up again when it returns.
// Details: docs/hardware/barometer.md.
#include <spdlog/spdlog.h>

#include <chrono>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/channels.hpp"
#include "core/cli.hpp"
#include "core/error_limiter.hpp"
#include "core/line_buffer.hpp"
#include "core/node.hpp"
#include "core/serial_port.hpp"
#include "core/site.hpp"
#include "core/text_escape.hpp"
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
  int rc = 0;
  if (!ips::parse_command_line(app, opts, argc, argv, rc)) return rc;

  auto usage_error = [](const std::string& what) {
    ips::print_fatal(kProgram, what + " (see --help)");
    return 2;
  };
  if (iio_specs.empty() && serial_specs.empty())
    return usage_error("give --iio and/or --serial (one per sensor)");
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
