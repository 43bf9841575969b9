// ips-uwb-can: UWB two-way ranges from a CAN bus (SocketCAN), a candump log or a candump stream,
// published as uwb_range_t on UWB_RANGE; and --to-candump, which writes the UWB_RANGE messages of
// an LCM log as `candump -L` lines. Frame layout and workflows: docs/hardware/uwb.md.
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <memory>
#include <optional>

#include "core/channels.hpp"
#include "core/cli.hpp"
#include "core/line_buffer.hpp"
#include "core/log_input.hpp"
#include "core/log_to_lines.hpp"
#include "core/node.hpp"
#include "core/paced_input.hpp"
#include "core/text_escape.hpp"
#include "drivers/uwb_can/can_range_receiver.hpp"
#include "drivers/uwb_can/candump_parser.hpp"
#include "drivers/uwb_can/socketcan_port.hpp"

namespace {

constexpr const char* kProgram = "ips-uwb-can";
using namespace ips::uwb_can;

struct Settings {
  RangeFrameLayout layout;
  RangeIds ids;
  TimeFrom time_from = TimeFrom::kHost;
  double speed = 1.0;
  bool fd = false;
};

// The node's counters and health for what the receiver finds.
CanRangeReceiver make_receiver(ips::Node& node, const Settings& s) {
  const std::string channel = node.options().channel(ips::channel::kUwbRange);
  CanRangeReceiver::Sink sink;
  sink.range = [&node, channel](const ips::uwb_range_t& m) { node.publish(channel, m); };
  sink.bad_input = [&node](const std::string& why) {
    ++node.counters().parse_errors;
    node.report_error(why);
  };
  sink.error_frame = [&node](const std::string& what) { node.report_error(what); };
  sink.lost = [&node](int64_t n, const std::string& why) {
    node.counters().drops += n;
    node.report_error(std::to_string(n) + " CAN frame(s) lost: " + why);
  };
  return CanRangeReceiver(s.layout, s.ids, std::move(sink));
}

void log_summary(const std::string& what, const CanRangeStats& st) {
  std::string other;
  for (const auto& [id, n] : st.other_ids) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%s0x%03X x%lld", other.empty() ? "" : ", ", id,
                  static_cast<long long>(n));
    other += buf;
  }
  spdlog::info(
      "{}: {}: {} frames, {} ranges published, {} bad, {} error frames, {} lost, {} not "
      "for us{}",
      kProgram, what, st.frames, st.ranges, st.bad_input, st.error_frames, st.lost_frames,
      st.other_frames, other.empty() ? "" : " (standard ids " + other + ")");
}

// --candump-file and --candump-stdin: candump text from `fd` until its end, paced by the line
// timestamps (core/paced_input.hpp). While a line waits for its time, the input is not read: a
// writer into the pipe (cat, candump) waits too.
int read_candump(ips::Node& node, const Settings& s, int fd, const std::string& name) {
  CanRangeReceiver rx = make_receiver(node, s);
  ips::PacedInput<CandumpLine> input(
      node, s.speed, 1,
      [](const CandumpLine& line) -> std::optional<ips::utime_t> {
        if (line.kind == CandumpLineKind::kFrame && line.has_time) return line.utime;
        return std::nullopt;
      },
      [&](const CandumpLine& line) { rx.on_candump_line(line, s.time_from, ips::wall_utime_now()); });
  ips::LineBuffer lines(kMaxCandumpLineBytes);
  int64_t n_lines = 0, overlong_seen = 0;
  std::string first_bad;
  auto take_line = [&](std::string_view text) {
    ++n_lines;
    CandumpLine line = parse_candump_line(text);
    if (line.kind == CandumpLineKind::kBad && first_bad.empty())
      first_bad = "line " + std::to_string(n_lines) + ": " + line.reason;
    if (line.kind == CandumpLineKind::kFrame) ++node.counters().msgs_in;
    input.push(std::move(line));
  };
  const int status = input.run(
      fd, kProgram, name,
      [&](std::string_view bytes) {
        lines.feed(bytes, take_line);
        for (; overlong_seen < lines.overlong_lines(); ++overlong_seen) {
          ++node.counters().parse_errors;
          node.report_error("candump line longer than " + std::to_string(kMaxCandumpLineBytes) +
                            " bytes skipped");
        }
      },
      [&] {
        if (const std::string rest = lines.take_partial(); !rest.empty()) take_line(rest);
      });
  const bool eof = input.eof();
  log_summary(name, rx.stats());
  if (rx.stats().bad_input > 0)
    spdlog::warn("{}: {}: {} bad lines or frames skipped (first: {})", kProgram, name,
                 rx.stats().bad_input, ips::printable(first_bad));
  if (status == 0 && eof && n_lines > 0 && rx.stats().frames == 0 && rx.stats().lost_frames == 0) {
    ips::print_fatal(kProgram, name + " is not candump text (no frame in it" +
                                   (first_bad.empty() ? "" : "; " + ips::printable(first_bad)) +
                                   ")");
    return 1;
  }
  return status;
}

// --interface: the CAN bus itself. A socket that fails later is reopened every second.
int read_socketcan(ips::Node& node, const Settings& s, std::unique_ptr<SocketCanPort> port) {
  CanRangeReceiver rx = make_receiver(node, s);
  const std::string interface = port->interface();
  uint32_t dropped_seen = 0;
  bool down = false;
  auto on_readable = [&](short) {
    // Bounded per wake-up so that timers and signals are served on a flooded bus.
    for (int i = 0; i < 512 && port; ++i) {
      CanFrame frame;
      ips::utime_t utime = 0;
      std::string error;
      const CanReadResult r = port->read(frame, utime, error);
      if (r == CanReadResult::kNone) return;
      if (r == CanReadResult::kFrame) {
        ++node.counters().msgs_in;
        if (down) {
          down = false;
          spdlog::info("{}: {} is up again", kProgram, interface);
        }
        if (port->dropped_total() != dropped_seen) {
          const uint32_t lost = port->dropped_total() - dropped_seen;
          dropped_seen = port->dropped_total();
          node.counters().drops += lost;
          node.report_error(std::to_string(lost) +
                            " CAN frame(s) dropped by a full socket receive queue");
        }
        rx.on_frame(frame, utime, interface);
      } else if (r == CanReadResult::kBadSize) {
        ++node.counters().parse_errors;
        node.report_error("read from " + interface + " returned an incomplete CAN frame");
      } else if (r == CanReadResult::kDown) {
        if (!down) node.report_error(interface + " is down: " + error);
        down = true;
        return;
      } else {
        node.report_error("CAN socket on " + interface + " failed (" + error +
                          "); reopening every second");
        node.set_state(ips::health_t::STATE_ERROR);
        node.unwatch_fd(port->fd());
        port.reset();
      }
    }
  };
  node.watch_fd(port->fd(), POLLIN, on_readable);
  node.add_timer(1.0, [&] {
    if (port) return;
    CanOpenFailure failure;
    std::string message, warning;
    port = SocketCanPort::open(interface, s.fd, failure, message, warning);
    if (!port) return;
    dropped_seen = 0;
    node.set_state(ips::health_t::STATE_DEGRADED);  // it was down: keep that visible
    spdlog::info("{}: {} reopened", kProgram, interface);
    node.watch_fd(port->fd(), POLLIN, on_readable);
  });
  spdlog::info("{}: reading UWB range frames on {} (ids 0x{:03X}..0x{:03X}{})", kProgram, interface,
               s.layout.base_id, s.layout.base_id + s.layout.anchor_count - 1,
               s.fd ? ", CAN FD" : "");
  const int rc = node.run();
  log_summary(interface, rx.stats());
  return rc;
}

// --to-candump: the UWB_RANGE messages of an LCM log as `candump -L` lines on stdout.
int to_candump(const ips::CommonOptions& opts, const Settings& s, const std::string& path,
               const std::string& interface) {
  return ips::write_log_as_lines<ips::uwb_range_t>(
      kProgram, path, opts.channel(ips::channel::kUwbRange), "candump line",
      [&](const ips::uwb_range_t& m, std::string& line, std::string& why) {
        if (!ips::plausible_utime(m.utime)) {
          why = "utime " + std::to_string(m.utime) + " is not a plausible time";
          return false;
        }
        const RangeRecordResult rec = range_record(m, s.ids);
        if (!rec.ok) {
          why = rec.reason;
          return false;
        }
        const RangeFrameEncode enc = encode_range_frame(rec.record, s.layout, s.fd);
        if (!enc.ok) {
          why = enc.reason;
          return false;
        }
        line = format_candump_line(enc.frame, m.utime, interface);
        return true;
      });
}

// "0x300", "768": an id as C writes it.
std::optional<uint32_t> parse_id_text(const std::string& text) {
  if (text.empty() || text.size() > 12) return std::nullopt;
  char* end = nullptr;
  errno = 0;
  const unsigned long v = std::strtoul(text.c_str(), &end, 0);
  if (errno != 0 || *end != '\0' || text[0] == '-' || text[0] == '+' || v > 0xFFFFFFFFul)
    return std::nullopt;
  return static_cast<uint32_t>(v);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "ips-uwb-can: UWB two-way ranges from CAN (SocketCAN, candump logs or a candump "
      "stream) published as uwb_range_t on UWB_RANGE; --to-candump writes an LCM log's "
      "UWB_RANGE messages as candump -L lines. Frame layout: docs/hardware/uwb.md.",
      kProgram};
  ips::CommonOptions opts;
  ips::add_common_options(app, opts, {.lcm = true, .site = false, .channels = true});
  std::string interface, candump_file, to_candump_log, base_id_text = "0x300", time_from;
  std::string anchor_prefix = "A", tag_prefix = "T";
  std::vector<std::string> anchor_maps, tag_maps;
  bool candump_stdin = false;
  Settings s;
  auto* o_if = app.add_option("--interface", interface,
                              "CAN interface to read (SocketCAN), e.g. can0; with --to-candump "
                              "the interface name written (default can0)");
  auto* o_file =
      app.add_option("--candump-file", candump_file,
                     "replay a candump log (candump -L/-l, or the screen format with -t a)")
          ->type_name("FILE");
  auto* o_stdin = app.add_flag("--candump-stdin", candump_stdin,
                               "read candump text on stdin, e.g. candump -L can0 | ips-uwb-can "
                               "--candump-stdin");
  auto* o_to = app.add_option("--to-candump", to_candump_log,
                              "write the UWB_RANGE messages of an LCM log as candump -L lines on "
                              "stdout, then exit")
                   ->type_name("LOG.lcm");
  auto* o_fd = app.add_flag("--fd", s.fd,
                            "--interface: also receive CAN FD frames (CAN_RAW_FD_FRAMES); "
                            "--to-candump: write CAN FD frames");
  app.add_option("--base-id", base_id_text, "CAN id of anchor 0 (standard 11-bit id)")
      ->capture_default_str();
  app.add_option("--anchors", s.layout.anchor_count,
                 "number of anchors: ids base-id .. base-id+anchors-1")
      ->capture_default_str();
  app.add_option("--anchor-prefix", anchor_prefix, "anchor id published for anchor N: PREFIX+N")
      ->capture_default_str();
  app.add_option("--tag-prefix", tag_prefix, "tag id published for tag N: PREFIX+N")
      ->capture_default_str();
  app.add_option("--anchor-id", anchor_maps, "name anchor N ID instead (repeatable)")
      ->type_name("N=ID");
  app.add_option("--tag-id", tag_maps, "name tag N ID instead (repeatable)")->type_name("N=ID");
  auto* o_time = app.add_option("--time-from", time_from,
                                "utime of candump input: 'line' (the line's timestamp; default "
                                "for --candump-file) or 'host' (time read; default for "
                                "--candump-stdin)")
                     ->check(CLI::IsMember({"line", "host"}));
  auto* o_speed = app.add_option("--speed", s.speed,
                                 "candump input: hand frames on at this speed by their line "
                                 "timestamps (never faster); 0: as fast as they are read")
                      ->capture_default_str()
                      ->check(CLI::Range(0.0, 1e6));
  int rc = 0;
  if (!ips::parse_command_line(app, opts, argc, argv, rc)) return rc;

  const int modes = (o_file->count() > 0) + (o_stdin->count() > 0) + (o_to->count() > 0) +
                    (o_if->count() > 0 && o_to->count() == 0);
  auto usage_error = [](const std::string& what) {
    ips::print_fatal(kProgram, what + " (see --help)");
    return 2;
  };
  if (modes != 1)
    return usage_error(
        "give exactly one of --interface, --candump-file, --candump-stdin, "
        "--to-candump");
  if (o_fd->count() > 0 && o_if->count() == 0 && o_to->count() == 0)
    return usage_error("--fd goes with --interface or --to-candump");
  if (o_speed->count() > 0 && o_file->count() == 0 && !candump_stdin)
    return usage_error("--speed goes with --candump-file or --candump-stdin");
  if (o_time->count() > 0 && o_file->count() == 0 && !candump_stdin)
    return usage_error("--time-from goes with --candump-file or --candump-stdin");
  const auto base_id = parse_id_text(base_id_text);
  if (!base_id) return usage_error("--base-id: '" + base_id_text + "' is not a number");
  s.layout.base_id = *base_id;
  if (const std::string why = s.layout.check(); !why.empty())
    return usage_error("--base-id/--anchors: " + why);
  s.ids = RangeIds{IdNumbering("tag", tag_prefix, 0xFFFF),
                   IdNumbering("anchor", anchor_prefix, s.layout.anchor_count - 1)};
  for (const auto& m : anchor_maps)
    if (const std::string why = s.ids.anchors.add(m); !why.empty())
      return usage_error("--anchor-id " + m + ": " + why);
  for (const auto& m : tag_maps)
    if (const std::string why = s.ids.tags.add(m); !why.empty())
      return usage_error("--tag-id " + m + ": " + why);
  for (const IdNumbering* n : {&s.ids.anchors, &s.ids.tags})
    if (const std::string why = n->check(); !why.empty()) return usage_error(why);
  if (o_if->count() > 0 && interface.empty()) return usage_error("--interface: empty name");
  const bool file_time = o_file->count() > 0 ? time_from != "host" : time_from == "line";
  s.time_from = file_time ? TimeFrom::kLine : TimeFrom::kHost;

  if (o_to->count() > 0) {
    const std::string name = interface.empty() ? "can0" : interface;
    if (parse_candump_line("(1767225600.000000) " + name + " 300#").kind != CandumpLineKind::kFrame)
      return usage_error("--interface: '" + name + "' cannot be written as a candump interface");
    return to_candump(opts, s, to_candump_log, name);
  }
  // The input before LCM: without AF_CAN, the interface or the file there is nothing to wait for.
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(nullptr, &std::fclose);
  if (o_file->count() > 0) {
    file.reset(std::fopen(candump_file.c_str(), "rb"));
    if (!file) {
      ips::print_fatal(kProgram,
                       "cannot read candump log '" + candump_file + "': " + std::strerror(errno));
      return 1;
    }
  }
  std::unique_ptr<SocketCanPort> port;
  if (o_if->count() > 0) {
    CanOpenFailure failure;
    std::string message, warning;
    port = SocketCanPort::open(interface, s.fd, failure, message, warning);
    if (!port) {
      ips::print_fatal(kProgram, message);
      return 1;
    }
    if (!warning.empty()) spdlog::warn("{}: {}", kProgram, warning);
  }
  return ips::run_reporting_errors(kProgram, [&] {
    ips::Node node(kProgram, opts);
    if (port) return read_socketcan(node, s, std::move(port));
    if (candump_stdin) return read_candump(node, s, STDIN_FILENO, "stdin");
    return read_candump(node, s, fileno(file.get()), "'" + candump_file + "'");
  });
}
