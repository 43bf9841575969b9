#pragma once
// Drives the DWM1001 PANS UART shell so that a tag streams `lec` lines (DWM1001 Firmware API
// Guide: the module starts in its binary TLV API; two carriage returns within a second open the
// shell, which prints a banner and the "dwm> " prompt; `lec` toggles CSV output of distances
// and position on and off; `quit` leaves the shell for the TLV API again).
//
// After each (re)open: listen for probe_s first (a tag left streaming by an earlier run must not
// be toggled off), then send "\r", "\r" enter_gap_s later, "lec\r" shell_wait_s after that, and
// wait data_timeout_s for a lec line; if none comes, start over ("lec" toggles, so one of two
// attempts finds it on). On exit, stop_commands() turns lec off and leaves the shell.
//
// Pure: the caller passes the time (s, any monotonic clock) and writes what poll() returns.
#include <string>
#include <vector>

namespace ips::uwb_serial {

class PansShell {
 public:
  struct Timing {
    double probe_s = 1.0;
    double enter_gap_s = 0.1;
    double shell_wait_s = 1.0;
    double data_timeout_s = 5.0;
  };
  enum class State { kClosed, kProbing, kEnterSent, kShellOpening, kLecSent, kStreaming };

  PansShell() = default;
  explicit PansShell(Timing timing) : timing_(timing) {}

  void on_open(double now_s);
  void on_close() { state_ = State::kClosed; }
  // A lec/lep data line arrived.
  void on_data_line();
  // Bytes to write now ("" when none).
  std::string poll(double now_s);
  // Commands to send, a short pause apart, before closing on exit ("lec\r" if lec may be on,
  // then "quit\r"); empty when nothing was sent and nothing streams.
  std::vector<std::string> stop_commands() const;
  // True while the shell is being started: its banner and echoes are expected then.
  bool starting() const {
    return state_ == State::kEnterSent || state_ == State::kShellOpening ||
           state_ == State::kLecSent;
  }
  State state() const { return state_; }
  int attempts() const { return attempts_; }  // shell start-ups begun since the last open

 private:
  Timing timing_;
  State state_ = State::kClosed;
  double next_s_ = 0;  // when the current state's deadline falls
  int attempts_ = 0;
};

}  // namespace ips::uwb_serial
