// ips-ble-aoa: u-blox XPLR-AOA anchors (C211, u-connectLocate) on serial ports, one port each
// -> ble_aoa_t on BLE_AOA, stamped with the host time each line was read. Keeps running while an
// anchor is unplugged and reopens it when it returns. With --capture, reads files instead: the
// source experiments' captures (PC time, port, +UUDF line) or files of decoded +UUDF fields (one
// per anchor, uudf_table.hpp), merged in time order onto the bus or into an LCM log.
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
#include "core/import_output.hpp"
#include "core/lcm_url.hpp"
#include "core/line_buffer.hpp"
#include "core/node.hpp"
#include "core/table_text.hpp"
#include "core/serial_port.hpp"
#include "core/text_escape.hpp"
#include "drivers/ble_aoa/at_enabler.hpp"
#include "drivers/ble_aoa/capture_decoder.hpp"
#include "drivers/ble_aoa/event_decoder.hpp"
#include "drivers/ble_aoa/uudf_table.hpp"

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

struct CaptureCounts {
  int64_t lines = 0, published = 0, at_lines = 0, duplicates = 0, range_unknown = 0, errors = 0;
  ips::table::ImportTally tally;  // for the verdict
};

void count(CaptureCounts& c, const LineOutcome& out, int64_t line_number, std::string_view line) {
  ++c.lines;
  ++c.tally.lines;
  switch (out.kind) {
    case LineOutcome::Kind::kPublished:
      ++c.published;
      ++c.tally.messages;
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
      c.tally.reject(line_number, line, out.reason);
      return;
  }
  ++c.tally.rows;
}

void summarise(const CaptureCounts& c, const std::string& where) {
  if (c.errors > kCaptureReasonsLogged)
    spdlog::warn("{}: ... and {} more bad lines", kProgram, c.errors - kCaptureReasonsLogged);
  spdlog::info(
      "{}: capture: {} lines, {} events {}, {} AT lines, {} duplicates dropped, {} dropped "
      "(angle range unknown), {} bad lines",
      kProgram, c.lines, c.published, where, c.at_lines, c.duplicates, c.range_unknown, c.errors);
}

// What every --capture file was read with.
struct CaptureSetup {
  EventDecoderConfig base;
  CaptureDecoder::ZoneConversion zone;  // capture-line files
  ips::ble_aoa::UudfTableOptions table;  // decoded-field files
};

// What --capture counted over all files, for HEALTH on the bus.
struct CaptureTotals {
  int64_t lines = 0, errors = 0, drops = 0;
};

// The whole file as lines (without newlines): the LineBuffer's, so a line longer than it takes
// is counted, not read.
bool read_lines(const std::string& path, std::vector<std::string>& lines, int64_t& overlong,
                std::string& error) {
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(std::fopen(path.c_str(), "rb"),
                                                       &std::fclose);
  if (!file) {
    error = "cannot read '" + ips::printable(path) + "': " + std::strerror(errno);
    return false;
  }
  ips::LineBuffer buffer;
  std::vector<char> buf(1 << 16);
  for (;;) {
    const size_t n = std::fread(buf.data(), 1, buf.size(), file.get());
    if (n == 0) break;
    buffer.feed(std::string_view(buf.data(), n),
                [&](std::string_view line) { lines.emplace_back(line); });
  }
  if (std::ferror(file.get())) {
    error = "read error on '" + ips::printable(path) + "': " + std::strerror(errno);
    return false;
  }
  std::string rest = buffer.take_partial();
  if (!rest.empty()) lines.push_back(std::move(rest));
  overlong = buffer.overlong_lines();
  return true;
}

std::string base_name(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

// One --capture file into `output`. The verdict line when it failed (nothing silent), else "".
std::string import_capture_file(const std::string& path, const std::vector<std::string>& lines,
                                int64_t overlong, const CaptureSetup& setup, bool only_file,
                                const std::string& where, ips::ImportOutput& output,
                                const std::string& channel, CaptureTotals& totals) {
  auto sink = [&](const ips::ble_aoa_t& m) { output.add(channel, m); };
  bool capture_lines = false;
  for (const std::string& line : lines) {
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    capture_lines = ips::ble_aoa::looks_like_capture_line(line);
    break;
  }
  if (capture_lines) {
    // The source experiments' capture: each port is an anchor of its own.
    CaptureDecoder decoder(kProgram, setup.base, setup.zone, sink);
    CaptureCounts counts;
    int64_t n = 0;
    for (const std::string& line : lines) count(counts, decoder.decode(line), ++n, line);
    counts.errors += overlong;
    counts.tally.bad += overlong;
    summarise(counts, only_file ? where : "from " + path);
    totals.lines += counts.lines;
    totals.errors += counts.errors;
    totals.drops += counts.duplicates + counts.range_unknown;
    ips::table::ImportExpectation expected;
    expected.input = path;
    expected.columns = "date time,port,+UUDF line";
    expected.separator = ',';
    return ips::table::import_verdict(counts.tally, expected);
  }
  // Decoded +UUDF fields: the file is the anchor's, whatever port its logger read.
  EventDecoderConfig config = setup.base;
  config.source = std::string(kProgram) + ":" + base_name(path);
  ips::ble_aoa::UudfTableDecoder decoder(setup.table, std::move(config), sink);
  for (const std::string& line : lines) decoder.decode(line);
  ips::table::ImportTally tally = decoder.tally();
  tally.bad += overlong;
  const ips::ble_aoa::EventDecoderStats& ev = decoder.events();
  totals.lines += tally.lines;
  totals.errors += tally.bad;
  totals.drops += ev.duplicates + ev.range_unknown;
  // A failed file says so in one line, nothing else.
  if (std::string verdict = ips::table::import_verdict(tally, decoder.expectation(path));
      !verdict.empty())
    return verdict;
  std::string text = path + ": " + std::to_string(tally.rows + tally.bad) + " rows (columns " +
                     decoder.columns();
  if (decoder.time_unit())
    text += std::string(", time in ") + ips::table::time_unit_name(*decoder.time_unit());
  text += "), " + std::to_string(tally.messages) + " events";
  if (tally.messages > 0)
    text += " from " + ips::utc_text(decoder.first_utime()) + " to " + ips::utc_text(decoder.last_utime());
  text += ", " + std::to_string(ev.duplicates) + " duplicates dropped, " +
          std::to_string(ev.range_unknown) + " dropped (angle range unknown), " +
          std::to_string(tally.bad) + " rows rejected";
  if (tally.bad > 0)
    text += " (first: line " + std::to_string(tally.first_bad_line) + ": " +
            tally.first_bad_reason + ")";
  spdlog::info("{}: {}", kProgram, text);
  return {};
}

// --capture FILE...: every file read whole, the events merged in time order, into an LCM log or
// onto the bus.
int run_capture(const std::vector<std::string>& paths, const std::string& out_path,
                const ips::CommonOptions& opts, const CaptureSetup& setup, double speed) {
  const std::string channel = opts.channel(ips::channel::kBleAoa);
  const std::string where = out_path.empty() ? "published" : "written to " + out_path;
  ips::ImportOutput output;
  CaptureTotals totals;
  bool failed = false;
  for (const std::string& path : paths) {
    std::vector<std::string> lines;
    int64_t overlong = 0;
    std::string error;
    if (!read_lines(path, lines, overlong, error)) {
      ips::print_fatal(kProgram, "--capture: " + error);
      return 1;
    }
    const std::string verdict = import_capture_file(path, lines, overlong, setup,
                                                    paths.size() == 1, where, output, channel,
                                                    totals);
    if (!verdict.empty()) {
      ips::print_fatal(kProgram, verdict);
      failed = true;
    }
  }
  if (failed) return 1;
  if (paths.size() > 1)
    spdlog::info("{}: {} events from {} files {}, {} to {}", kProgram, output.size(), paths.size(),
                 where, ips::utc_text(output.first_utime()), ips::utc_text(output.last_utime()));
  return ips::write_or_publish(
      kProgram, output, out_path, opts, speed, {totals.lines, totals.errors, totals.drops},
      [&](ips::Node&) {
        spdlog::info("{}: replaying {} events on {} ({})", kProgram, output.size(),
                     ips::effective_lcm_url(opts.lcm_url),
                     speed > 0 ? "speed x" + std::to_string(speed)
                               : std::string("as fast as possible"));
      });
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
  std::vector<std::string> capture_paths, tag_names;
  std::string out_path, zone_name = "UTC", angle_range_name = "pm90";
  std::string separator_name, columns, header_name = "auto", time_unit_name;
  double speed = 0.0;
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
  app.add_option("--tag-name", tag_names,
                 "publish tag HWID (its id in the events, e.g. a MAC or a number) as ID, e.g. the "
                 "site file's T1 (repeatable)")
      ->type_name("HWID=ID");
  auto* o_capture =
      app.add_option("--capture", capture_paths,
                     "read files instead of devices: captures (date time,port,+UUDF line) or "
                     "decoded +UUDF fields (time,tag,rssi,azimuth,elevation,channel,anchor,seq; "
                     "one file per anchor), merged in time order")
          ->type_name("FILE...")
          ->expected(1, -1);
  auto* o_out = app.add_option("--out", out_path,
                               "--capture: write a standard LCM log instead of publishing")
                    ->type_name("FILE.lcm");
  auto* o_speed =
      app.add_option("--speed", speed,
                     "--capture: publish paced by the files' times at this speed factor "
                     "(default: as fast as possible)")
          ->check(CLI::Range(1e-3, 1e6));
  auto* o_fast = app.add_flag("--as-fast-as-possible", as_fast,
                              "--capture: publish without pacing (the default)");
  auto* o_tz = app.add_option("--timezone", zone_name,
                              "--capture: the zone of a capture's PC clock: UTC, +HH:MM, or a "
                              "name such as Europe/Prague")
                   ->capture_default_str();
  auto* o_sep = app.add_option("--separator", separator_name,
                               "decoded fields: , ; tab or space (default: detected)")
                    ->type_name("SEP");
  auto* o_columns =
      app.add_option("--columns", columns,
                     "decoded fields: the columns in order, of t,tag,rssi,azimuth,elevation,"
                     "rssi2,channel,anchor,seq,uptime,user,uudf ('-' skips one; default: by the "
                     "header's names, else detected)")
          ->type_name("LIST");
  auto* o_header = app.add_option("--header", header_name,
                                   "decoded fields: auto, none (the first line is data) or yes")
                       ->capture_default_str();
  auto* o_unit = app.add_option("--time-unit", time_unit_name,
                                "decoded fields: s, ms, us or ns for numeric times (default: "
                                "guessed from the first epoch time; ISO-8601 always read)")
                     ->type_name("UNIT");
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
    for (const auto* o : {o_out, o_speed, o_fast, o_tz, o_sep, o_columns, o_header, o_unit})
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
  for (const std::string& spec : tag_names) {
    const size_t eq = spec.find('=');
    const std::string hw = spec.substr(0, eq);
    const std::string id = eq == std::string::npos ? "" : spec.substr(eq + 1);
    if (eq == std::string::npos || !ips::ble_aoa::valid_id(hw) || !ips::ble_aoa::valid_id(id))
      return usage_error("--tag-name: '" + ips::printable(spec) +
                         "' is not HWID=ID (each 1 to 32 of A-Za-z0-9_.:-)");
    if (!base.tag_names.emplace(hw, id).second)
      return usage_error("--tag-name: " + hw + " is named twice");
  }

  if (capture) {
    CaptureSetup setup;
    setup.base = base;
    const auto zone = zone_conversion(zone_name);
    if (!zone)
      return usage_error("--timezone: '" + ips::printable(zone_name) +
                         "' is not UTC, +HH:MM or a zone name of the system's database");
    setup.zone = *zone;
    if (o_sep->count() > 0) {
      setup.table.read.separator = ips::table::separator_from_name(separator_name);
      if (!setup.table.read.separator)
        return usage_error("--separator: expected , ; tab or space, got '" +
                           ips::printable(separator_name) + "'");
    }
    if (header_name == "none") {
      setup.table.read.header = ips::table::HeaderMode::kNone;
    } else if (header_name == "yes") {
      setup.table.read.header = ips::table::HeaderMode::kPresent;
    } else if (header_name != "auto") {
      return usage_error("--header: expected auto, none or yes, got '" +
                         ips::printable(header_name) + "'");
    }
    if (o_unit->count() > 0) {
      setup.table.time_unit = ips::table::time_unit_from_name(time_unit_name);
      if (!setup.table.time_unit)
        return usage_error("--time-unit: expected s, ms, us or ns, got '" +
                           ips::printable(time_unit_name) + "'");
    }
    if (o_columns->count() > 0) {
      ips::table::Columns check;
      if (const std::string problem =
              check.set_from_list(columns, ips::ble_aoa::uudf_table_columns());
          !problem.empty())
        return usage_error("--columns: " + problem);
      setup.table.columns = columns;
    }
    std::set<std::string> seen_files;
    for (const std::string& path : capture_paths) {
      struct stat st {};
      if (stat(path.c_str(), &st) != 0)
        return usage_error("--capture: cannot read '" + ips::printable(path) +
                           "': " + std::strerror(errno));
      if (S_ISDIR(st.st_mode))
        return usage_error("--capture: '" + ips::printable(path) + "' is a directory");
      if (!seen_files.insert(path).second)
        return usage_error("--capture: '" + ips::printable(path) + "' is given twice");
    }
    return run_capture(capture_paths, out_path, opts, setup, as_fast ? 0.0 : speed);
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
