#include "drivers/uwb_serial/pans_shell.hpp"

namespace ips::uwb_serial {

void PansShell::on_open(double now_s) {
  state_ = State::kProbing;
  next_s_ = now_s + timing_.probe_s;
  attempts_ = 0;
}

void PansShell::on_data_line() {
  if (state_ != State::kClosed) state_ = State::kStreaming;
}

std::string PansShell::poll(double now_s) {
  if (state_ == State::kClosed || state_ == State::kStreaming || now_s < next_s_) return "";
  switch (state_) {
    case State::kProbing:
    case State::kLecSent:  // no lec line in time: start over
      ++attempts_;
      state_ = State::kEnterSent;
      next_s_ = now_s + timing_.enter_gap_s;
      return "\r";
    case State::kEnterSent:
      state_ = State::kShellOpening;
      next_s_ = now_s + timing_.shell_wait_s;
      return "\r";
    case State::kShellOpening:
      state_ = State::kLecSent;
      next_s_ = now_s + timing_.data_timeout_s;
      return "lec\r";
    case State::kClosed:
    case State::kStreaming:
      break;
  }
  return "";
}

std::vector<std::string> PansShell::stop_commands() const {
  switch (state_) {
    case State::kClosed:
    case State::kProbing:
      return {};
    case State::kEnterSent:
    case State::kShellOpening:
      return {"quit\r"};
    case State::kLecSent:
    case State::kStreaming:
      return {"lec\r", "quit\r"};
  }
  return {};
}

}  // namespace ips::uwb_serial
