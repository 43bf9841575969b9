// ips-ble-aoa: u-blox XPLR-AOA anchors (C211, u-connectLocate) on serial ports, one port each
// -> ble_aoa_t on BLE_AOA, stamped with the host time each line was read. Keeps running while an
// anchor is unplugged and reopens it when it returns. With --capture, replays a capture file of
// the source experiments (PC time, port, +UUDF line) onto the bus or into an LCM log.
#include <spdlog/spdlog.h>
#include <sys/stat.h>
#include <time.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <lcm/lcm-cpp.hpp>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "core/channels.hpp"
#include "core/cli.hpp"
#include "core/lcm_url.hpp"
#include "core/line_buffer.hpp"
#include "core/node.hpp"
#include "core/paced_release.hpp"
#include "core/progress.hpp"
#include "core/serial_port.hpp"
#include "core/text_escape.hpp"
#include "drivers/ble_aoa/at_enabler.hpp"
#include "drivers/ble_aoa/capture_decoder.hpp"
#include "drivers/ble_aoa/event_decoder.hpp"

namespace {

using ips::ble_aoa::AtEnabler;
using ips::ble_aoa::CaptureDecoder;
using ips::ble_aoa::EventDecoder;
using ips::ble_aoa::EventDecoderConfig;
using ips::ble_aoa::LineOutcome;

constexpr const char* kProgram = "ips-ble-aoa";
// Bad capture lines logged one by one; the rest only counted.
constexpr int64_t kCaptureReasonsLogged = 20;

double monotonic_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// --timezone: UTC or a fixed offset (pure), else a zone of the system's database read with
// mktime (TZ set for this process; it only ever reads the capture's clock).
std::optional<CaptureDecoder::ZoneConversion> zone_conversion(const std::string& name) {
  if (const auto offset = ips::ble_aoa::parse_utc_offset(name)) {
    const int64_t off = *offset;
    return CaptureDecoder::ZoneConversion(
        [off](const ips::ble_aoa::CivilTime& t) { return ips::ble_aoa::utime_from_civil(t, off); });
  }
  if (name.empty() || name.find("..") != std::string::npos || name[0] == '/') return std::nullopt;
  for (char c : name)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '/' || c == '_' || c == '-' ||
          c == '+'))
      return std::nullopt;
  const char* dir = std::getenv("TZDIR");
  const std::string path = std::string(dir && *dir ? dir : "/usr/share/zoneinfo") + "/" + name;
  struct stat st {};
  if (stat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) return std::nullopt;
  setenv("TZ", name.c_str(), 1);
  tzset();
  return CaptureDecoder::ZoneConversion(
      [](const ips::ble_aoa::CivilTime& t) -> std::optional<int64_t> {
        std::tm tm{};
        tm.tm_year = t.year - 1900;
        tm.tm_mon = t.month - 1;
        tm.tm_mday = t.day;
        tm.tm_hour = t.hour;
        tm.tm_min = t.minute;
        tm.tm_sec = t.second;
        tm.tm_isdst = -1;
        const std::time_t s = std::mktime(&tm);
        // A time skipped by a daylight-saving change comes back normalised to another one.
        if (s <= 0 || tm.tm_hour != t.hour || tm.tm_min != t.minute || tm.tm_mday != t.day)
          return std::nullopt;
        const int64_t us = static_cast<int64_t>(s) * 1'000'000 + t.micros;
        if (!ips::plausible_utime(us)) return std::nullopt;
        return us;
      });
}

// One anchor port in live mode.
struct AnchorPort {
  std::string path;
  ips::LineBuffer lines;
  int64_t overlong_reported = 0;
  std::unique_ptr<EventDecoder> decoder;
  std::unique_ptr<AtEnabler> enabler;
  std::unique_ptr<ips::SerialLink> link;
};

void apply(ips::Node& node, AnchorPort& port, const AtEnabler::Step& step) {
  if (!step.write.empty()) {
    spdlog::debug("{}: {}: sending {}", kProgram, port.path, ips::printable(step.write));
    port.link->write(step.write);
  }
  if (!step.info.empty()) spdlog::info("{}: {}: {}", kProgram, port.path, step.info);
  if (!step.failure.empty()) node.report_error(port.path + ": " + step.failure);
}

int run_live(const ips::CommonOptions& opts, const std::vector<std::string>& devices,
             const ips::SerialLinkOptions& serial, const EventDecoderConfig& base,
             const std::vector<std::string>* at_commands) {
  ips::Node node(kProgram, opts);
  const std::string channel = opts.channel(ips::channel::kBleAoa);
  std::vector<std::unique_ptr<AnchorPort>> ports;
  auto publish = [&](const ips::ble_aoa_t& m) { node.publish(channel, m); };
  for (const std::string& path : devices) {
    auto port = std::make_unique<AnchorPort>();
    AnchorPort& p = *port;
    p.path = path;
    EventDecoderConfig config = base;
    config.source = std::string(kProgram) + ":" + path;
    p.decoder = std::make_unique<EventDecoder>(std::move(config), publish);
    if (at_commands)
      p.enabler = std::make_unique<AtEnabler>(AtEnabler::commands_with(*at_commands));
    auto on_line = [&node, &p](std::string_view line, ips::utime_t utime) {
      ++node.counters().msgs_in;
      const LineOutcome out = p.decoder->decode(line, utime);
      switch (out.kind) {
        case LineOutcome::Kind::kPublished:
          break;
        case LineOutcome::Kind::kAtLine:
          if (p.enabler) apply(node, p, p.enabler->on_line(out.at, line, monotonic_s()));
          spdlog::debug("{}: {}: {}", kProgram, p.path, ips::printable(line));
          break;
        case LineOutcome::Kind::kDuplicate:
          ++node.counters().drops;
          spdlog::debug("{}: {}: dropped a duplicate event", kProgram, p.path);
          break;
        case LineOutcome::Kind::kRangeUnknown:
          ++node.counters().drops;
          spdlog::debug("{}: {}: dropped an event: angle range not known yet", kProgram, p.path);
          break;
        case LineOutcome::Kind::kError:
          ++node.counters().parse_errors;
          node.report_error("skipped line from " + p.path + ": " + out.reason);
          break;
      }
    };
    ips::SerialLinkOptions link_options = serial;
    link_options.path = path;
    p.link = std::make_unique<ips::SerialLink>(
        node, link_options,
        ips::SerialLink::Callbacks{
            .on_open =
                [&p] {
                  p.lines.reset();  // a partial line belongs to the device's previous life
                  if (p.enabler) p.enabler->on_open(monotonic_s());
                },
            .on_bytes =
                [&node, &p, on_line](std::string_view bytes, ips::utime_t utime) {
                  p.lines.feed(bytes, [&](std::string_view line) { on_line(line, utime); });
                  if (p.lines.overlong_lines() != p.overlong_reported) {
                    node.counters().parse_errors += p.lines.overlong_lines() - p.overlong_reported;
                    p.overlong_reported = p.lines.overlong_lines();
                    node.report_error("skipped a line longer than 4096 bytes from " + p.path);
                  }
                },
            .on_close =
                [&p] {
                  if (p.enabler) p.enabler->on_close();
                },
        });
    ports.push_back(std::move(port));
  }
  if (at_commands) {
    node.add_timer(0.05, [&] {
      for (auto& p : ports) apply(node, *p, p->enabler->poll(monotonic_s()));
    });
  }
  for (auto& p : ports) {
    std::string error;
    if (!p->link->start(error)) {
      ips::print_fatal(kProgram, "--device " + ips::printable(error));
      return 2;
    }
  }
  const int status = node.run();
  for (auto& p : ports) p->link.reset();  // before the node
  return status;
}

// Reads `file` in chunks, hands every line over; on_line returns false to stop.
template <class OnLine>
bool for_each_line(std::FILE* file, int64_t size, OnLine&& on_line, ips::LineBuffer& lines,
                   int64_t& offset) {
  std::vector<char> buf(1 << 16);
  bool go_on = true;
  for (;;) {
    const size_t n = std::fread(buf.data(), 1, buf.size(), file);
    if (n == 0) break;
    offset += static_cast<int64_t>(n);
    const double fraction = size > 0 ? static_cast<double>(offset) / static_cast<double>(size) : 1;
    lines.feed(std::string_view(buf.data(), n), [&](std::string_view line) {
      if (go_on) go_on = on_line(line, fraction);
    });
    if (!go_on) return false;
  }
  const std::string rest = lines.take_partial();
  if (!rest.empty()) return on_line(rest, 1.0);
  return true;
}

struct CaptureCounts {
  int64_t lines = 0, published = 0, at_lines = 0, duplicates = 0, range_unknown = 0, errors = 0;
};

void count(CaptureCounts& c, const LineOutcome& out, int64_t line_number) {
  ++c.lines;
  switch (out.kind) {
    case LineOutcome::Kind::kPublished:
      ++c.published;
      break;
    case LineOutcome::Kind::kAtLine:
      ++c.at_lines;
      break;
    case LineOutcome::Kind::kDuplicate:
      ++c.duplicates;
      break;
    case LineOutcome::Kind::kRangeUnknown:
      ++c.range_unknown;
      break;
    case LineOutcome::Kind::kError:
      if (++c.errors <= kCaptureReasonsLogged)
        spdlog::warn("{}: capture line {}: {}", kProgram, line_number, out.reason);
      break;
  }
}

void summarise(const CaptureCounts& c, const std::string& where) {
  if (c.errors > kCaptureReasonsLogged)
    spdlog::warn("{}: ... and {} more bad lines", kProgram, c.errors - kCaptureReasonsLogged);
  spdlog::info(
      "{}: capture: {} lines, {} events {}, {} AT lines, {} duplicates dropped, {} dropped "
      "(angle range unknown), {} bad lines",
      kProgram, c.lines, c.published, where, c.at_lines, c.duplicates, c.range_unknown, c.errors);
}

int write_capture_log(std::FILE* file, int64_t size, const std::string& out_path,
                      const ips::CommonOptions& opts, const EventDecoderConfig& base,
                      const CaptureDecoder::ZoneConversion& zone) {
  lcm::LogFile log(out_path, "w");
  if (!log.good()) {
    ips::print_fatal(kProgram, "--out: cannot write '" + out_path + "'");
    return 1;
  }
  const std::string channel = opts.channel(ips::channel::kBleAoa);
  std::vector<uint8_t> buf;
  bool write_failed = false;
  int64_t eventnum = 0;
  CaptureDecoder decoder(kProgram, base, zone, [&](const ips::ble_aoa_t& m) {
    buf.resize(static_cast<size_t>(m.getEncodedSize()));
    m.encode(buf.data(), 0, static_cast<int>(buf.size()));
    lcm::LogEvent le;
    le.eventnum = eventnum++;
    le.timestamp = m.utime;
    le.channel = channel;
    le.datalen = static_cast<int32_t>(buf.size());
    le.data = buf.data();
    if (log.writeEvent(&le) != 0) write_failed = true;
  });
  ips::ProgressLine progress(kProgram);
  ips::LineBuffer lines;
  CaptureCounts counts;
  int64_t offset = 0;
  for_each_line(
      file, size,
      [&](std::string_view line, double fraction) {
        count(counts, decoder.decode(line), counts.lines + 1);
        progress.update(fraction, counts.published);
        return !write_failed;
      },
      lines, offset);
  // The log's last buffer is written at close: check it here, not in LogFile's silent destructor.
  if (write_failed || std::fflush(log.getFilePtr()) != 0 || std::ferror(log.getFilePtr())) {
    ips::print_fatal(kProgram, "write to '" + out_path + "' failed (disk full?)");
    return 1;
  }
  progress.finish();
  counts.errors += lines.overlong_lines();
  summarise(counts, "written to " + out_path);
  return 0;
}

int publish_capture(std::FILE* file, int64_t size, const ips::CommonOptions& opts,
                    const EventDecoderConfig& base, const CaptureDecoder::ZoneConversion& zone,
                    double speed) {
  ips::Node node(kProgram, opts);
  const std::string channel = opts.channel(ips::channel::kBleAoa);
  // Paced by the capture's own times: message k goes out (utime_k - utime_0) / speed after the
  // first; a time earlier than one already sent (the logger's threads) goes out at once.
  bool stopped = false;
  ips::PacedRelease pace(node, speed);
  CaptureDecoder decoder(kProgram, base, zone, [&](const ips::ble_aoa_t& m) {
    if (stopped || !pace.wait(m.utime)) {
      stopped = true;
      return;
    }
    node.publish(channel, m);
  });
  spdlog::info("{}: replaying the capture on {} ({})", kProgram,
               ips::effective_lcm_url(opts.lcm_url),
               speed > 0 ? "speed x" + std::to_string(speed) : std::string("as fast as possible"));
  ips::ProgressLine progress(kProgram);
  ips::LineBuffer lines;
  CaptureCounts counts;
  int64_t offset = 0;
  for_each_line(
      file, size,
      [&](std::string_view line, double fraction) {
        const LineOutcome out = decoder.decode(line);
        if (stopped) return false;
        ++node.counters().msgs_in;
        if (out.kind == LineOutcome::Kind::kError) ++node.counters().parse_errors;
        if (out.kind == LineOutcome::Kind::kDuplicate ||
            out.kind == LineOutcome::Kind::kRangeUnknown)
          ++node.counters().drops;
        count(counts, out, counts.lines + 1);
        progress.update(fraction, counts.published);
        return true;
      },
      lines, offset);
  if (stopped) return 0;  // SIGINT/SIGTERM
  progress.finish();
  node.counters().parse_errors += lines.overlong_lines();
  counts.errors += lines.overlong_lines();
  node.publish_health();
  summarise(counts, "published");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "ips-ble-aoa: reads u-blox XPLR-AOA anchors (+UUDF angle-of-arrival events), one serial "
      "port each, and publishes every event as ble_aoa_t on BLE_AOA with the host time it was "
      "read. --capture replays a capture file of the source experiments (date time,port,+UUDF "
      "line) onto the bus, or into an LCM log with --out. Details: docs/hardware/ble-aoa.md.",
      kProgram};
  ips::CommonOptions opts;
  ips::add_common_options(app, opts, {.lcm = true, .site = false, .channels = true});
  std::vector<std::string> devices, anchor_names, at_commands;
  ips::SerialLinkOptions serial;
  std::string capture_path, out_path, zone_name = "UTC", angle_range_name = "pm90";
  double speed = 1.0;
  bool as_fast = false, enable_events = false;
  EventDecoderConfig base;
  auto* o_device =
      app.add_option("--device", devices,
                     "an anchor's serial port, e.g. /dev/ttyACM0 (repeat for each anchor)")
          ->type_name("PATH");
  app.add_option("--baud", serial.baud, "line speed, 8N1")->capture_default_str();
  app.add_option("--reopen-s", serial.reopen_s,
                 "retry period while a device is missing or unplugged, s")
      ->capture_default_str()
      ->check(CLI::Range(0.05, 3600.0));
  auto* o_enable = app.add_flag("--enable-events", enable_events,
                                "switch the events on over AT after each open: ATE0, AT+UMLA=1, "
                                "the --at-command ones, AT+UDFENABLE=1");
  auto* o_at = app.add_option("--at-command", at_commands,
                              "an extra AT command sent before AT+UDFENABLE=1, e.g. "
                              "AT+UDFCFG=1,50 (repeatable; needs --enable-events)")
                   ->type_name("CMD");
  app.add_option("--angle-range", angle_range_name,
                 "angles the firmware reports: pm90 (-90..90, current firmware), 0-180 (older "
                 "firmware), auto (per anchor, from what it sends)")
      ->capture_default_str();
  app.add_option("--legacy-offset-deg", base.legacy_offset_deg,
                 "0..180 firmware: angle = raw - this (an assumption: the source does not say)")
      ->capture_default_str()
      ->check(CLI::Range(-360.0, 360.0));
  app.add_option("--duplicate-window-s", base.duplicate_window_s,
                 "events without a counter: identical events this close are one")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 60.0));
  app.add_option("--anchor-name", anchor_names,
                 "publish anchor HWID (its id in +UUDF, e.g. the MAC 6C1DEBA09862) as ID, e.g. "
                 "the site file's A1 (repeatable)")
      ->type_name("HWID=ID");
  auto* o_capture = app.add_option("--capture", capture_path,
                                   "replay a capture file (date time,port,+UUDF line per line) "
                                   "instead of reading devices")
                        ->type_name("FILE");
  auto* o_out = app.add_option("--out", out_path,
                               "--capture: write a standard LCM log as fast as possible instead "
                               "of publishing")
                    ->type_name("FILE.lcm");
  auto* o_speed = app.add_option("--speed", speed, "--capture: playback speed factor")
                      ->capture_default_str()
                      ->check(CLI::Range(1e-3, 1e6));
  auto* o_fast =
      app.add_flag("--as-fast-as-possible", as_fast, "--capture: publish without pacing");
  auto* o_tz = app.add_option("--timezone", zone_name,
                              "--capture: the zone of the capture's PC clock: UTC, +HH:MM, or a "
                              "name such as Europe/Prague")
                   ->capture_default_str();
  o_speed->excludes(o_fast);
  o_out->excludes(o_speed);
  o_out->excludes(o_fast);
  if (auto* url_opt = app.get_option_no_throw("--lcm-url")) o_out->excludes(url_opt);
  int rc = 0;
  if (!ips::parse_command_line(app, opts, argc, argv, rc)) return rc;

  auto usage_error = [](const std::string& what) {
    ips::print_fatal(kProgram, what);
    return 2;
  };
  const bool capture = o_capture->count() > 0;
  if (capture && o_device->count() > 0)
    return usage_error("--device and --capture exclude each other");
  if (!capture && devices.empty())
    return usage_error("--device (one per anchor) or --capture is required");
  if (!capture) {
    for (const auto* o : {o_out, o_speed, o_fast, o_tz})
      if (o->count() > 0) return usage_error(o->get_name() + " goes with --capture");
  } else if (o_enable->count() > 0) {
    return usage_error("--enable-events goes with --device");
  }
  if (o_at->count() > 0 && !enable_events) return usage_error("--at-command needs --enable-events");
  for (const std::string& c : at_commands) {
    bool printable = c.size() >= 2 && c.size() <= 128 && (c[0] == 'A' || c[0] == 'a') &&
                     (c[1] == 'T' || c[1] == 't');
    for (char ch : c)
      if (ch < 0x20 || ch > 0x7e) printable = false;
    if (!printable)
      return usage_error("--at-command: '" + ips::printable(c) +
                         "' is not an AT command (AT..., printable, at most 128 characters)");
  }
  const auto range = ips::ble_aoa::angle_range_from_name(angle_range_name);
  if (!range)
    return usage_error("--angle-range: expected pm90, 0-180 or auto, got '" +
                       ips::printable(angle_range_name) + "'");
  base.angle_range = *range;
  for (const std::string& spec : anchor_names) {
    const size_t eq = spec.find('=');
    const std::string hw = spec.substr(0, eq);
    const std::string id = eq == std::string::npos ? "" : spec.substr(eq + 1);
    if (eq == std::string::npos || !ips::ble_aoa::valid_id(hw) || !ips::ble_aoa::valid_id(id))
      return usage_error("--anchor-name: '" + ips::printable(spec) +
                         "' is not HWID=ID (each 1 to 32 of A-Za-z0-9_.:-)");
    if (!base.anchor_names.emplace(hw, id).second)
      return usage_error("--anchor-name: " + hw + " is named twice");
  }

  if (capture) {
    const auto zone = zone_conversion(zone_name);
    if (!zone)
      return usage_error("--timezone: '" + ips::printable(zone_name) +
                         "' is not UTC, +HH:MM or a zone name of the system's database");
    std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(std::fopen(capture_path.c_str(), "rb"),
                                                         &std::fclose);
    if (!file)
      return usage_error("--capture: cannot read '" + ips::printable(capture_path) +
                         "': " + std::strerror(errno));
    struct stat st {};
    if (fstat(fileno(file.get()), &st) != 0 || S_ISDIR(st.st_mode))
      return usage_error("--capture: '" + ips::printable(capture_path) + "' is a directory");
    const int64_t size = S_ISREG(st.st_mode) ? static_cast<int64_t>(st.st_size) : 0;
    if (!out_path.empty()) return write_capture_log(file.get(), size, out_path, opts, base, *zone);
    return ips::run_reporting_errors(kProgram, [&] {
      return publish_capture(file.get(), size, opts, base, *zone, as_fast ? 0.0 : speed);
    });
  }

  if (!ips::serial_baud_supported(serial.baud))
    return usage_error("--baud: " + std::to_string(serial.baud) +
                       " is not a speed termios can set (e.g. 9600, 115200, 921600)");
  std::set<std::string> seen;
  for (const std::string& path : devices) {
    if (const std::string problem = ips::serial_path_problem(path); !problem.empty())
      return usage_error("--device " + ips::printable(path) + ": " + problem);
    if (!seen.insert(path).second)
      return usage_error("--device " + ips::printable(path) + " is given twice");
  }
  return ips::run_reporting_errors(kProgram, [&] {
    return run_live(opts, devices, serial, base, enable_events ? &at_commands : nullptr);
  });
}
