#pragma once
// Switches an XPLR-AOA anchor's +UUDF events on over its AT interface (u-connectLocate; u-blox
// XPLR-AOA user guide, appendix A): commands end with a carriage return, the anchor answers
// "OK" or "ERROR" on a line of its own, and echoes each command while echo is on (the default).
//
// The conversation after each (re)open, and again after "+STARTUP" (the anchor rebooted):
//   wait settle_s (the port may still deliver what the anchor printed before),
//   ATE0              echo off, so that only answers and events follow
//   AT+UMLA=1         the anchor's Bluetooth address (+UMLA:...; the default anchor id)
//   <extra commands>  e.g. AT+UDFCFG=1,50 (at least 50 ms between a tag's events)
//   AT+UDFENABLE=1    angle calculation on: +UUDF events start
// one at a time, each waiting for OK. ERROR stops the conversation (kFailed) and names the
// command; no answer within response_timeout_s starts it over, at most max_attempts times, then
// kFailed. Events that arrive meanwhile are the caller's to publish: an anchor configured to
// calculate angles at start-up (+UDFCFG tag 3) streams without us.
//
// Pure: the caller passes the time (s, any monotonic clock), writes Step::write to the port,
// reports Step::failure in health_t and logs Step::info.
#include <string>
#include <string_view>
#include <vector>

#include "drivers/ble_aoa/uudf_parser.hpp"

namespace ips::ble_aoa {

class AtEnabler {
 public:
  struct Timing {
    double settle_s = 0.2;
    double response_timeout_s = 2.0;
    int max_attempts = 3;
  };
  enum class State { kClosed, kSettling, kWaiting, kEnabled, kFailed };
  struct Step {
    std::string write;    // bytes to send now ("" when none)
    std::string failure;  // the conversation failed: why ("" when it did not)
    std::string info;     // worth a log line ("" when nothing)
  };

  // ATE0, AT+UMLA=1, `extra` (without their "\r"), AT+UDFENABLE=1.
  static std::vector<std::string> commands_with(const std::vector<std::string>& extra);

  explicit AtEnabler(std::vector<std::string> commands) : commands_(std::move(commands)) {}
  AtEnabler(std::vector<std::string> commands, Timing timing)
      : commands_(std::move(commands)), timing_(timing) {}

  void on_open(double now_s);
  void on_close() { state_ = State::kClosed; }
  // A line of the AT conversation arrived (see parse_uudf_line); `line` for the log.
  Step on_line(AtLine kind, std::string_view line, double now_s);
  // What to do now.
  Step poll(double now_s);

  State state() const { return state_; }
  // The command waiting for its answer ("" when none).
  std::string_view pending() const;
  int attempts() const { return attempts_; }

 private:
  Step send(size_t index, double now_s);

  std::vector<std::string> commands_;
  Timing timing_;
  State state_ = State::kClosed;
  size_t index_ = 0;   // the command sent last
  double next_s_ = 0;  // the current state's deadline
  int attempts_ = 0;   // conversations begun since the last open or +STARTUP
};

}  // namespace ips::ble_aoa
