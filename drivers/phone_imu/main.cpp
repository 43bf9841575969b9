// ips-phone-imu: phones streaming their inertial sensors -> imu_t on IMU, phone time mapped to
// host time. Live: UDP datagrams of CSV rows (IMU+GPS-Stream, HyperIMU; csv_row.hpp) and/or HTTP
// POSTs of Sensor Logger JSON batches (sensor_logger_json.hpp, core/http_server.hpp). --file
// imports a recorded file (delimited text of any separator and time unit, or rows at a --rate;
// file_import.hpp) into a log (--out) or onto the bus.
// Apps, settings, formats, time mapping: docs/hardware/phone.md.
#include <spdlog/spdlog.h>
#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <lcm/lcm-cpp.hpp>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/channels.hpp"
#include "core/cli.hpp"
#include "core/device_text.hpp"
#include "core/error_limiter.hpp"
#include "core/http_server.hpp"
#include "core/import_output.hpp"
#include "core/lcm_url.hpp"
#include "core/node.hpp"
#include "core/progress.hpp"
#include "core/text_escape.hpp"
#include "core/udp_socket.hpp"
#include "drivers/phone_imu/csv_row.hpp"
#include "drivers/phone_imu/file_import.hpp"
#include "drivers/phone_imu/phone_streams.hpp"
#include "drivers/phone_imu/sensor_logger_json.hpp"

namespace {

using namespace ips::phone_imu;
using ips::ErrorLimiter;
using ips::http::HttpReply;
using ips::http::HttpRequest;
using ips::http::HttpServer;
using ips::http::HttpServerOptions;

constexpr const char* kProgram = "ips-phone-imu";

bool valid_device_id(std::string_view id) {
  if (id.empty() || id.size() > 64) return false;
  for (char c : id)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '.' || c == ':' ||
          c == '-'))
      return false;
  return true;
}

bool valid_ipv4(const std::string& a) {
  unsigned b[4];
  char extra;
  if (std::sscanf(a.c_str(), "%3u.%3u.%3u.%3u%c", &b[0], &b[1], &b[2], &b[3], &extra) != 4)
    return false;
  return b[0] < 256 && b[1] < 256 && b[2] < 256 && b[3] < 256;
}

struct Settings {
  RowFormat udp_format;
  JsonSensorNames json_names;
  PhoneStreamsConfig streams;
  std::string device_id;  // --device-id, empty: from the sender
  std::string udp_bind = "127.0.0.1", http_bind = "127.0.0.1";
  int udp_port = 0, http_port = 0;
  size_t max_datagram_bytes = 4096;
  HttpServerOptions http;
  std::string http_path = "/data";
};

// --- live: UDP and HTTP ----------------------------------------------------------------------

class Live {
 public:
  Live(ips::Node& node, const Settings& s)
      : node_(node),
        s_(s),
        channel_(node.options().channel(ips::channel::kImu)),
        streams_(s.streams, [this](const ips::imu_t& m) { node_.publish(channel_, m); }) {}

  void bad(const std::string& kind, const std::string& text, int64_t n = 1) {
    node_.counters().parse_errors += n;
    if (auto line = limiter_.admit(kind, text, ips::wall_utime_now())) node_.report_error(*line);
  }
  void dropped(const std::string& kind, const std::string& text, int64_t n) {
    node_.counters().drops += n;
    if (auto line = limiter_.admit(kind, text, ips::wall_utime_now())) node_.report_error(*line);
  }

  void publish_batch(const std::string& device, int64_t host_us, std::vector<SensorSample>& b) {
    const BatchResult r = streams_.on_batch(device, host_us, b);
    if (r.clock_reset)
      spdlog::info("{}: {}: phone clock jumped; time mapping restarted (offset {:.6f} s)", kProgram,
                   device, static_cast<double>(r.offset_us) * 1e-6);
    if (r.dropped > 0)
      dropped("assembler",
              device + ": " + std::to_string(r.dropped) +
                  " reading(s) dropped: not newer than the last, or time not mappable",
              r.dropped);
  }

  void on_datagram(std::string_view d, const std::string& sender, int64_t host_us) {
    ++node_.counters().msgs_in;
    batch_.clear();
    int64_t bad_rows = 0;
    std::string first;
    size_t start = 0;
    while (start < d.size()) {
      size_t end = d.find('\n', start);
      if (end == std::string_view::npos) end = d.size();
      std::string_view row = d.substr(start, end - start);
      start = end + 1;
      while (!row.empty() && (row.back() == '\r' || row.back() == ' ')) row.remove_suffix(1);
      if (row.empty()) continue;
      const RowParse p = parse_row(row, s_.udp_format);
      if (!p.ok) {
        if (bad_rows++ == 0) first = p.reason;
        continue;
      }
      batch_.insert(batch_.end(), p.samples.begin(), p.samples.begin() + p.count);
    }
    if (bad_rows > 0) bad("udp", "skipped datagram row from " + sender + ": " + first, bad_rows);
    publish_batch(s_.device_id.empty() ? sender : s_.device_id, host_us, batch_);
  }

  HttpReply on_post(const HttpRequest& r, const std::string& peer, int64_t host_us) {
    ++node_.counters().msgs_in;
    JsonBatch b = parse_sensor_logger_batch(r.body, s_.json_names);
    if (!b.ok) {
      bad("json", "refused POST from " + peer + ": " + b.reason);
      return {400,
              "application/json",
              "{\"status\":\"error\",\"reason\":" + ips::json_quote(b.reason) + "}",
              {}};
    }
    if (b.bad_entries > 0)
      bad("json", "skipped payload entries from " + peer + ": " + b.first_bad, b.bad_entries);
    const std::string device = !s_.device_id.empty()          ? s_.device_id
                               : valid_device_id(b.device_id) ? b.device_id
                                                              : peer;
    const int64_t accepted = static_cast<int64_t>(b.samples.size());
    publish_batch(device, host_us, b.samples);
    return {200,
            "application/json",
            "{\"status\":\"ok\",\"accepted\":" + std::to_string(accepted) +
                ",\"rejected\":" + std::to_string(b.bad_entries) + "}",
            {}};
  }

  // `connections`: the server's counts (stats_text), told with the connections cut (408, 503).
  void on_refused(int status, const std::string& reason, const std::string& peer,
                  const std::string& connections) {
    ++node_.counters().msgs_in;
    const std::string text = "HTTP " + std::to_string(status) + " to " + peer + ": " + reason;
    if (status == 408 || status == 503)  // a slow, silent or evicted connection; no slot
      dropped("http-connection", text + " (connections so far: " + connections + ")", 1);
    else if (status == 404 || status == 405)
      dropped("http", text, 1);
    else
      bad("http", text);
  }

 private:
  ips::Node& node_;
  const Settings& s_;
  std::string channel_;
  PhoneStreams streams_;
  ErrorLimiter limiter_;
  std::vector<SensorSample> batch_;
};

int run_live(const ips::CommonOptions& opts, Settings& s) {
  ips::Node node(kProgram, opts);
  s.streams.source = kProgram;
  Live live(node, s);
  std::unique_ptr<ips::UdpSocket> udp;
  std::unique_ptr<HttpServer> http;
  std::string error;
  if (s.udp_port > 0) {
    udp = std::make_unique<ips::UdpSocket>(
        node, s.max_datagram_bytes,
        ips::UdpSocket::Callbacks{
            .on_datagram = [&](std::string_view d, const std::string& sender,
                               ips::utime_t t) { live.on_datagram(d, sender, t); },
            .on_dropped =
                [&](int64_t n) {
                  live.dropped("udp-queue",
                               std::to_string(n) + " datagram(s) dropped: receive queue full", n);
                },
            .on_truncated =
                [&](const std::string& sender) {
                  ++node.counters().msgs_in;
                  live.bad("udp", "skipped datagram from " + sender + ": longer than " +
                                      std::to_string(s.max_datagram_bytes) + " bytes");
                },
        });
    if (!udp->open(s.udp_bind, static_cast<uint16_t>(s.udp_port), error)) {
      ips::print_fatal(kProgram, "--udp-port: " + error);
      return 1;
    }
    spdlog::info("{}: CSV datagrams on UDP {}:{}", kProgram, s.udp_bind, udp->bound_port());
  }
  if (s.http_port > 0) {
    s.http.addr = s.http_bind;
    s.http.port = static_cast<uint16_t>(s.http_port);
    http = std::make_unique<HttpServer>(
        node, s.http,
        HttpServer::Callbacks{
            .on_refused =
                [&](int status, const std::string& reason, const std::string& peer) {
                  live.on_refused(status, reason, peer, ips::http::stats_text(http->stats()));
                },
        });
    http->route("POST", s.http_path,
                [&](const HttpRequest& r, const std::string& peer, ips::utime_t t) {
                  return live.on_post(r, peer, t);
                });
    if (!http->open(error)) {
      ips::print_fatal(kProgram, "--http-port: " + error);
      return 1;
    }
    spdlog::info("{}: Sensor Logger HTTP push on http://{}:{}{}", kProgram, s.http_bind,
                 http->bound_port(), s.http_path);
  }
  const int rc = node.run();
  if (http)  // every refusal and cut, by status: what HEALTH counts as drops and parse errors
    spdlog::info("{}: HTTP connections: {}", kProgram, ips::http::stats_text(http->stats()));
  http.reset();
  udp.reset();
  return rc;
}

// --- file import -----------------------------------------------------------------------------

// Longer lines are cut here (and then rejected as rows): a binary file has no line ends.
constexpr size_t kMaxLineBytes = 1 << 16;

std::string span_text(int64_t first_us, int64_t last_us) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "%.3f to %.3f s (%.1f s)", static_cast<double>(first_us) * 1e-6,
                static_cast<double>(last_us) * 1e-6,
                static_cast<double>(last_us - first_us) * 1e-6);
  return buf;
}

// Reads the file's lines (empty ones too, so line numbers are the file's) into a FileImport whose
// messages ImportOutput keeps, then writes them into a log (--out) or publishes them; nothing
// silent: an import with nothing or mostly rejected rows ends with one error line, status 1.
int import_file(std::FILE* file, int64_t size, const FileImportOptions& fo,
                const std::string& out_path, const ips::CommonOptions& opts, double speed) {
  ips::ImportOutput output;
  const std::string channel = opts.channel(ips::channel::kImu);
  FileImport import(fo, [&](const ips::imu_t& m) { output.add(channel, m); });
  if (!import.setup_error().empty()) {
    ips::print_fatal(kProgram, import.setup_error() + " (see --help)");
    return 2;
  }
  ips::ProgressLine progress(kProgram);
  std::vector<char> buf(1 << 16);
  std::string line;
  int64_t offset = 0;
  for (;;) {
    const size_t n = std::fread(buf.data(), 1, buf.size(), file);
    if (n == 0) break;
    offset += static_cast<int64_t>(n);
    for (size_t i = 0; i < n; ++i) {
      const char c = buf[i];
      if (c == '\n') {
        if (!line.empty() && line.back() == '\r') line.pop_back();
        import.feed(line);
        line.clear();
      } else if (line.size() < kMaxLineBytes) {
        line.push_back(c);
      }
    }
    progress.update(size > 0 ? static_cast<double>(offset) / static_cast<double>(size) : 1,
                    output.size());
  }
  if (std::ferror(file)) {
    ips::print_fatal(kProgram, "--file: read error on '" + ips::printable(fo.input) + "'");
    return 1;
  }
  if (!line.empty()) {
    if (line.back() == '\r') line.pop_back();
    import.feed(line);
  }
  progress.finish();
  const std::string verdict = import.finish();
  if (!verdict.empty()) {
    ips::print_fatal(kProgram, verdict);
    return 1;
  }
  spdlog::info("{}: {}: {}", kProgram, ips::printable(fo.input), import.describe());
  for (const std::string& w : import.warnings())
    spdlog::warn("{}: {}: {}", kProgram, ips::printable(fo.input), w);
  const ips::table::ImportTally& t = import.tally();
  std::string summary = std::to_string(t.rows + t.bad) + " rows read, " +
                        std::to_string(t.messages) + " messages " +
                        (out_path.empty() ? "published" : "written to " + out_path) + ", " +
                        std::to_string(t.bad) + " rows rejected";
  if (t.bad > 0)
    summary += " (first: line " + std::to_string(t.first_bad_line) + " '" + t.first_bad_text +
               "': " + t.first_bad_reason + ")";
  if (import.dropped() > 0)
    summary += ", " + std::to_string(import.dropped()) +
               " readings dropped (not newer than the previous, or time not plausible)";
  summary += ", " + span_text(import.first_utime(), import.last_utime());
  return ips::write_or_publish(
      kProgram, output, out_path, opts, speed, {t.lines, t.bad, import.dropped()},
      [&](ips::Node& node) {
        if (t.bad > 0)
          node.report_error("file: " + std::to_string(t.bad) + " rows rejected, the first: line " +
                            std::to_string(t.first_bad_line) + ": " + t.first_bad_reason);
      },
      [&] { spdlog::info("{}: {}", kProgram, summary); });
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "ips-phone-imu: phones streaming their inertial sensors, published as imu_t on IMU with the "
      "phone's time mapped to host time. --udp-port: CSV datagrams (IMU+GPS-Stream, HyperIMU); "
      "--http-port: Sensor Logger HTTP Push JSON; --file: a recorded file (any separator, time "
      "unit "
      "and columns, or rows at a --rate), into an LCM log (--out) or onto the bus. Details: "
      "docs/hardware/phone.md.",
      kProgram};
  ips::CommonOptions opts;
  ips::add_common_options(app, opts, {.lcm = true, .site = false, .channels = true});
  Settings s;
  std::string columns = "tagged", file_columns, separator, header = "auto", file_start;
  std::string udp_time = "s", file_time, accel_unit = "m/s2", gyro_unit = "rad/s", mag_unit = "uT",
              assemble = "accel", file_path, out_path;
  double pair_window_s = 0.05, speed = 0, start_s = 0, rate_hz = 0;
  bool as_fast = false;
  auto* o_udp = app.add_option("--udp-port", s.udp_port, "receive CSV datagrams on this UDP port")
                    ->check(CLI::Range(1, 65535));
  auto* o_udp_bind = app.add_option("--udp-bind", s.udp_bind,
                                    "address to receive datagrams on (0.0.0.0: every interface, "
                                    "for phones on the Wi-Fi)")
                         ->capture_default_str()
                         ->type_name("ADDR");
  auto* o_columns = app.add_option("--columns", columns,
                                   "--udp-port: the datagrams' columns, tagged (IMU+GPS-Stream: "
                                   "time, id, x, y, z, ...) or names, e.g. "
                                   "t,ax,ay,az,gx,gy,gz,mx,my,mz (HyperIMU). --file: the file's "
                                   "columns by position ('-' skips one, e.g. t,-,ax,ay,az; "
                                   "default: by the header's names, else "
                                   "t,ax,ay,az,gx,gy,gz,mx,my,mz)")
                        ->default_str("tagged");
  auto* o_udp_time =
      app.add_option("--udp-time-unit", udp_time, "unit of the datagrams' time: s, ms, us, ns")
          ->capture_default_str();
  auto* o_max_dgram = app.add_option("--max-datagram-bytes", s.max_datagram_bytes,
                                     "longer datagrams are skipped and counted")
                          ->capture_default_str()
                          ->check(CLI::Range(64, 65507));
  auto* o_http = app.add_option("--http-port", s.http_port,
                                "accept Sensor Logger HTTP Push POSTs on this TCP port")
                     ->check(CLI::Range(1, 65535));
  auto* o_http_bind = app.add_option("--http-bind", s.http_bind,
                                     "address to listen on (0.0.0.0: every interface, for phones "
                                     "on the Wi-Fi)")
                          ->capture_default_str()
                          ->type_name("ADDR");
  auto* o_path = app.add_option("--http-path", s.http_path, "the path the app POSTs to")
                     ->capture_default_str();
  auto* o_body = app.add_option("--max-body-bytes", s.http.limits.max_body_bytes,
                                "larger POST bodies are refused with 413")
                     ->capture_default_str()
                     ->check(CLI::Range(1024, 64 << 20));
  auto* o_conns = app.add_option("--max-connections", s.http.max_connections,
                                 "HTTP connections at once (when all are taken, a new one evicts "
                                 "an idle or unfinished one; 503 when none is)")
                      ->capture_default_str()
                      ->check(CLI::Range(1, 256));
  auto* o_peer_conns =
      app.add_option("--max-connections-per-peer", s.http.max_connections_per_peer,
                     "HTTP connections at once from one address (0: --max-connections)")
          ->capture_default_str()
          ->check(CLI::Range(0, 256));
  auto* o_head_timeout =
      app.add_option("--header-timeout", s.http.header_timeout_s,
                     "seconds from a connection's accept to a whole request head (else 408)")
          ->capture_default_str()
          ->check(CLI::Range(0.1, 60.0));
  auto* o_jacc = app.add_option("--json-accel", s.json_names.accel,
                                "Sensor Logger entry read as the accelerometer (with gravity)")
                     ->capture_default_str();
  auto* o_jgyr =
      app.add_option("--json-gyro", s.json_names.gyro, "Sensor Logger entry read as the gyroscope")
          ->capture_default_str();
  auto* o_jmag =
      app.add_option("--json-mag", s.json_names.mag, "Sensor Logger entry read as the magnetometer")
          ->capture_default_str();
  auto* o_file = app.add_option("--file", file_path,
                                "import a recorded file: delimited text (separator detected), "
                                "columns by --columns or by the header's names")
                     ->type_name("FILE");
  auto* o_sep = app.add_option("--separator", separator,
                               "--file: the separator: , ; tab space (default: detected from the "
                               "first data line)");
  auto* o_header = app.add_option("--header", header,
                                  "--file: auto (a non-numeric line before the data is the "
                                  "header), none, yes")
                       ->capture_default_str();
  auto* o_ftime = app.add_option("--time-unit", file_time,
                                 "--file: unit of the time column: s, ms, us, ns (default: "
                                 "guessed from the magnitude of an epoch time, else s)");
  auto* o_start = app.add_option("--file-start", file_start,
                                 "--file: Unix time (s) or ISO-8601 date-time of the first row, "
                                 "for times since boot, or with --rate")
                      ->type_name("T");
  auto* o_rate = app.add_option("--rate", rate_hz,
                                "--file: the file has no time column; row k is at --file-start + "
                                "k / HZ")
                     ->type_name("HZ")
                     ->check(CLI::Range(1e-3, 1e6));
  // Deprecated spellings of the three above (before the shared file reader).
  auto* o_fcols =
      app.add_option("--file-columns", file_columns, "deprecated: --columns with --file");
  auto* o_ftime_old = app.add_option("--file-time-unit", file_time, "deprecated: --time-unit");
  auto* o_start_old = app.add_option("--file-start-s", start_s, "deprecated: --file-start");
  auto* o_out =
      app.add_option("--out", out_path, "--file: write a standard LCM log instead of publishing")
          ->type_name("FILE.lcm");
  auto* o_speed = app.add_option("--speed", speed,
                                 "--file: publish paced by the file's own times at this speed "
                                 "factor (default: as fast as possible)")
                      ->check(CLI::Range(1e-3, 1e6));
  auto* o_fast = app.add_flag("--as-fast-as-possible", as_fast,
                              "--file: publish without pacing (the default; kept for old "
                              "command lines)");
  app.add_option("--accel-unit", accel_unit, "UDP and file accelerometer unit: m/s2 or g")
      ->capture_default_str();
  app.add_option("--gyro-unit", gyro_unit, "UDP and file gyroscope unit: rad/s or deg/s")
      ->capture_default_str();
  app.add_option("--mag-unit", mag_unit, "UDP and file magnetometer unit: uT or mG")
      ->capture_default_str();
  app.add_option("--assemble", assemble,
                 "accel: one message per accelerometer reading with the latest gyroscope and "
                 "magnetometer; per-sample: one per reading, the others NaN")
      ->capture_default_str();
  app.add_option("--pair-window-s", pair_window_s,
                 "accel: gyroscope/magnetometer readings older than this are NaN")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 10.0));
  app.add_option("--clock-window-s", s.streams.clock.window_s,
                 "time mapping: sliding window of the minimum-delay offset")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 600.0));
  app.add_option("--clock-jump-s", s.streams.clock.jump_s,
                 "time mapping: an offset change larger than this is a phone clock jump")
      ->capture_default_str()
      ->check(CLI::Range(0.1, 3600.0));
  auto* o_dev = app.add_option("--device-id", s.device_id,
                               "device_id of every message (default: the JSON deviceId or the "
                               "sender's address; for --file: phone)")
                    ->type_name("ID");
  o_speed->excludes(o_fast);
  o_out->excludes(o_speed);
  o_out->excludes(o_fast);
  if (auto* url_opt = app.get_option_no_throw("--lcm-url")) o_out->excludes(url_opt);
  int rc = 0;
  if (!ips::parse_command_line(app, opts, argc, argv, rc)) return rc;

  auto usage_error = [](const std::string& what) {
    ips::print_fatal(kProgram, what + " (see --help)");
    return 2;
  };
  const bool file = o_file->count() > 0;
  const bool live = o_udp->count() > 0 || o_http->count() > 0;
  if (file && live) return usage_error("--file excludes --udp-port and --http-port");
  if (!file && !live) return usage_error("give --udp-port and/or --http-port, or --file");
  if (!file)
    for (const auto* o : {o_fcols, o_ftime, o_ftime_old, o_start, o_start_old, o_out, o_speed,
                          o_fast, o_sep, o_header, o_rate})
      if (o->count() > 0) return usage_error(o->get_name() + " goes with --file");
  if (o_fcols->count() > 0 && o_columns->count() > 0)
    return usage_error("--file-columns is the old name of --columns: give one of them");
  if (o_ftime->count() + o_ftime_old->count() > 1)
    return usage_error("--file-time-unit is the old name of --time-unit: give one of them");
  if (o_start->count() > 0 && o_start_old->count() > 0)
    return usage_error("--file-start-s is the old name of --file-start: give one of them");
  if (o_udp->count() == 0)
    for (const auto* o : {o_udp_bind, o_udp_time, o_max_dgram})
      if (o->count() > 0) return usage_error(o->get_name() + " goes with --udp-port");
  if (o_http->count() == 0)
    for (const auto* o : {o_http_bind, o_path, o_body, o_conns, o_peer_conns, o_head_timeout,
                          o_jacc, o_jgyr, o_jmag})
      if (o->count() > 0) return usage_error(o->get_name() + " goes with --http-port");
  UnitScales units;
  if (!accel_scale_from_name(accel_unit, units.accel))
    return usage_error("--accel-unit: expected m/s2 or g, got '" + ips::printable(accel_unit) +
                       "'");
  if (!gyro_scale_from_name(gyro_unit, units.gyro))
    return usage_error("--gyro-unit: expected rad/s or deg/s, got '" + ips::printable(gyro_unit) +
                       "'");
  if (!mag_scale_from_name(mag_unit, units.mag))
    return usage_error("--mag-unit: expected uT or mG, got '" + ips::printable(mag_unit) + "'");
  s.udp_format.units = units;
  if (const auto u = time_unit_from_name(udp_time))
    s.udp_format.time_unit = *u;
  else
    return usage_error("--udp-time-unit: expected s, ms, us or ns, got '" +
                       ips::printable(udp_time) + "'");
  s.udp_format.separator = ',';
  if (!file && o_udp->count() == 0 && o_columns->count() > 0)
    return usage_error("--columns goes with --udp-port or --file");
  if (!file)
    if (const std::string why = parse_column_mapping(columns, s.udp_format); !why.empty())
      return usage_error("--columns: " + why);
  if (assemble != "accel" && assemble != "per-sample")
    return usage_error("--assemble: expected accel or per-sample, got '" +
                       ips::printable(assemble) + "'");
  s.streams.assembler.per_sample = assemble == "per-sample";
  s.streams.assembler.window_us = ips::s_to_utime(pair_window_s);
  if (o_dev->count() > 0 && !valid_device_id(s.device_id))
    return usage_error("--device-id: '" + ips::printable(s.device_id) +
                       "' is not 1 to 64 of A-Za-z0-9_.:-");
  for (const auto& [name, addr] :
       {std::pair{"--udp-bind", s.udp_bind}, std::pair{"--http-bind", s.http_bind}})
    if (!valid_ipv4(addr))
      return usage_error(std::string(name) + ": '" + ips::printable(addr) +
                         "' is not an IPv4 address (e.g. 127.0.0.1 or 0.0.0.0)");
  if (s.http_path.empty() || s.http_path[0] != '/' || !ips::printable_ascii(s.http_path) ||
      s.http_path.find_first_of(" ?#") != std::string::npos)
    return usage_error("--http-path: '" + ips::printable(s.http_path) +
                       "' is not a path such as /data");
  if (o_start_old->count() > 0) {
    if (!(start_s > 0 && start_s < 4e12))
      return usage_error("--file-start-s: not a Unix time in seconds");
    file_start = std::to_string(start_s);
  }

  if (file) {
    std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(file_path.c_str(), "rb"),
                                                      &std::fclose);
    if (!f)
      return usage_error("--file: cannot read '" + ips::printable(file_path) +
                         "': " + std::strerror(errno));
    struct stat st {};
    if (fstat(fileno(f.get()), &st) != 0 || S_ISDIR(st.st_mode))
      return usage_error("--file: '" + ips::printable(file_path) + "' is a directory");
    const int64_t size = S_ISREG(st.st_mode) ? static_cast<int64_t>(st.st_size) : 0;
    FileImportOptions fo;
    fo.input = ips::printable(file_path);
    if (o_columns->count() > 0)
      fo.columns = columns;
    else if (o_fcols->count() > 0)
      fo.columns = file_columns;
    if (o_sep->count() > 0) {
      fo.read.separator = ips::table::separator_from_name(separator);
      if (!fo.read.separator)
        return usage_error("--separator: expected , ; tab or space, got '" +
                           ips::printable(separator) + "'");
    }
    if (header == "auto")
      fo.read.header = ips::table::HeaderMode::kAuto;
    else if (header == "none")
      fo.read.header = ips::table::HeaderMode::kNone;
    else if (header == "yes")
      fo.read.header = ips::table::HeaderMode::kPresent;
    else
      return usage_error("--header: expected auto, none or yes, got '" + ips::printable(header) +
                         "'");
    if (!file_time.empty()) {
      fo.time_unit = ips::table::time_unit_from_name(file_time);
      if (!fo.time_unit)
        return usage_error("--time-unit: expected s, ms, us or ns, got '" +
                           ips::printable(file_time) + "'");
    }
    if (!file_start.empty()) {
      double v = 0;
      int64_t us = 0;
      if (ips::table::parse_number(file_start, v) && v > 0 && v < 4e12)
        fo.start_utime = static_cast<int64_t>(std::llround(v * 1e6));
      else if (ips::table::parse_iso8601_us(file_start, us) && ips::plausible_utime(us))
        fo.start_utime = us;
      else
        return usage_error("--file-start: '" + ips::printable(file_start) +
                           "' is not a Unix time in s or an ISO-8601 date-time after 1970");
    }
    fo.rate_hz = rate_hz;
    fo.units = units;
    fo.assembler = s.streams.assembler;
    fo.device_id = s.device_id.empty() ? "phone" : s.device_id;
    fo.source = std::string(kProgram) + ":file";
    return import_file(f.get(), size, fo, out_path, opts, as_fast ? 0.0 : speed);
  }
  return ips::run_reporting_errors(kProgram, [&] { return run_live(opts, s); });
}
