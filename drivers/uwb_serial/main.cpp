// ips-uwb-serial: a UWB tag or listener on a serial port (DWM1001 PANS `lec` lines or our RANGE
// line protocol) -> uwb_range_t on UWB_RANGE, and the module's own position -> pose_t on
// POSE_UWB_MODULE. Keeps running while the device is unplugged and reopens it when it returns.
#include <spdlog/spdlog.h>

#include <chrono>
#include <memory>
#include <thread>

#include "core/channels.hpp"
#include "core/cli.hpp"
#include "core/line_buffer.hpp"
#include "core/node.hpp"
#include "core/serial_port.hpp"
#include "core/text_escape.hpp"
#include "drivers/uwb_serial/line_decoder.hpp"
#include "drivers/uwb_serial/pans_shell.hpp"
#include "drivers/uwb_serial/range_line_parser.hpp"

namespace {

constexpr const char* kProgram = "ips-uwb-serial";

double monotonic_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "ips-uwb-serial: reads a UWB tag or listener on a serial port (DWM1001 PANS lec "
      "lines or RANGE lines) and publishes its ranges (UWB_RANGE) and its on-board "
      "position (POSE_UWB_MODULE).",
      kProgram};
  ips::CommonOptions opts;
  ips::add_common_options(app, opts, {.lcm = true, .site = false, .channels = true});
  ips::SerialLinkOptions serial;
  std::string format_name = "pans";
  std::string tag_id;
  bool pans_shell = false;
  app.add_option("--device", serial.path, "serial device, e.g. /dev/ttyACM0")->required();
  app.add_option("--baud", serial.baud, "line speed, 8N1")->capture_default_str();
  app.add_option("--format", format_name,
                 "pans (DWM1001 lec lines), line (RANGE lines) or auto (either, by first word)")
      ->capture_default_str();
  app.add_option("--tag", tag_id, "the tag's id for PANS lines (they do not carry it)");
  app.add_flag("--pans-shell", pans_shell,
               "drive the DWM1001 shell: open it, start lec, stop lec and quit on exit");
  app.add_option("--reopen-s", serial.reopen_s,
                 "retry period while the device is missing or unplugged, s")
      ->capture_default_str()
      ->check(CLI::Range(0.05, 3600.0));
  int rc = 0;
  if (!ips::parse_command_line(app, opts, argc, argv, rc)) return rc;

  const auto format = ips::uwb_serial::line_format_from_name(format_name);
  if (!format) {
    ips::print_fatal(kProgram, "--format: expected pans, line or auto, got '" + format_name + "'");
    return 2;
  }
  if (!ips::serial_baud_supported(serial.baud)) {
    ips::print_fatal(kProgram, "--baud: " + std::to_string(serial.baud) +
                                   " is not a speed termios can set (e.g. 9600, 115200, 921600)");
    return 2;
  }
  if (pans_shell && *format == ips::uwb_serial::LineFormat::kRangeLine) {
    ips::print_fatal(kProgram, "--pans-shell needs --format pans or auto");
    return 2;
  }
  if ((*format == ips::uwb_serial::LineFormat::kPans || pans_shell) && tag_id.empty()) {
    ips::print_fatal(kProgram,
                     "--tag ID is required for PANS lec lines (they do not carry the "
                     "tag's own id; the shell command si shows it)");
    return 2;
  }
  if (!tag_id.empty() && !ips::uwb_serial::valid_range_line_id(tag_id)) {
    ips::print_fatal(kProgram,
                     "--tag: '" + ips::printable(tag_id) + "' is not 1 to 32 of A-Za-z0-9_.:-");
    return 2;
  }
  if (const std::string problem = ips::serial_path_problem(serial.path); !problem.empty()) {
    ips::print_fatal(kProgram, "--device " + ips::printable(serial.path) + ": " + problem);
    return 2;
  }

  return ips::run_reporting_errors(kProgram, [&] {
    ips::Node node(kProgram, opts);
    const std::string range_channel = opts.channel(ips::channel::kUwbRange);
    const std::string pose_channel = opts.channel(ips::channel::kPoseUwbModule);
    ips::uwb_serial::LineDecoder decoder(
        {*format, tag_id, std::string(kProgram) + ":" + serial.path},
        [&](const ips::uwb_range_t& m) { node.publish(range_channel, m); },
        [&](const ips::pose_t& m) { node.publish(pose_channel, m); });
    std::unique_ptr<ips::uwb_serial::PansShell> shell;
    if (pans_shell) shell = std::make_unique<ips::uwb_serial::PansShell>();

    ips::LineBuffer lines;
    int64_t overlong_reported = 0;
    auto on_line = [&](std::string_view line, ips::utime_t utime) {
      ++node.counters().msgs_in;
      const auto out = decoder.decode(line, utime);
      if (out.kind == ips::uwb_serial::LineOutcome::Kind::kMeasurement) {
        if (shell && shell->state() != ips::uwb_serial::PansShell::State::kStreaming) {
          shell->on_data_line();
          spdlog::info("{}: receiving lec lines", kProgram);
        }
        if (out.position_without_fix) ++node.counters().drops;
      } else if (out.kind == ips::uwb_serial::LineOutcome::Kind::kError) {
        if (shell && shell->starting()) {  // the shell's banner and echoes
          spdlog::debug("{}: shell: {}", kProgram, ips::printable(std::string(line)));
          return;
        }
        ++node.counters().parse_errors;
        node.report_error("skipped line: " + out.reason);
      }
    };
    ips::SerialLink link(
        node, serial,
        ips::SerialLink::Callbacks{
            .on_open =
                [&] {
                  lines.reset();  // a partial line belongs to the device's previous life
                  if (shell) shell->on_open(monotonic_s());
                },
            .on_bytes =
                [&](std::string_view bytes, ips::utime_t utime) {
                  lines.feed(bytes, [&](std::string_view line) { on_line(line, utime); });
                  if (lines.overlong_lines() != overlong_reported) {
                    node.counters().parse_errors += lines.overlong_lines() - overlong_reported;
                    overlong_reported = lines.overlong_lines();
                    node.report_error("skipped a line longer than 4096 bytes");
                  }
                },
            .on_close =
                [&] {
                  if (shell) shell->on_close();
                },
        });
    if (shell) {
      node.add_timer(0.05, [&] {
        if (const std::string bytes = shell->poll(monotonic_s()); !bytes.empty()) {
          if (bytes == "lec\r") spdlog::info("{}: PANS shell open, starting lec", kProgram);
          link.write(bytes);
        }
      });
    }
    std::string error;
    if (!link.start(error)) {
      ips::print_fatal(kProgram, "--device " + ips::printable(error));
      return 2;
    }
    const int status = node.run();
    if (shell && link.is_open()) {
      // Leave the tag as it powers up: lec off, shell closed.
      for (const std::string& command : shell->stop_commands()) {
        link.write(command);
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
      }
      link.port().drain(500);
    }
    return status;
  });
}
