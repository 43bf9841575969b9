#include "drivers/ble_aoa/at_enabler.hpp"

#include "core/text_escape.hpp"

namespace ips::ble_aoa {

std::vector<std::string> AtEnabler::commands_with(const std::vector<std::string>& extra) {
  std::vector<std::string> c{"ATE0", "AT+UMLA=1"};
  c.insert(c.end(), extra.begin(), extra.end());
  c.emplace_back("AT+UDFENABLE=1");
  return c;
}

void AtEnabler::on_open(double now_s) {
  state_ = State::kSettling;
  next_s_ = now_s + timing_.settle_s;
  attempts_ = 0;
}

std::string_view AtEnabler::pending() const {
  return state_ == State::kWaiting ? std::string_view(commands_[index_]) : std::string_view();
}

AtEnabler::Step AtEnabler::send(size_t index, double now_s) {
  Step step;
  index_ = index;
  state_ = State::kWaiting;
  next_s_ = now_s + timing_.response_timeout_s;
  step.write = commands_[index] + "\r";
  return step;
}

AtEnabler::Step AtEnabler::poll(double now_s) {
  Step step;
  if ((state_ != State::kSettling && state_ != State::kWaiting) || now_s < next_s_) return step;
  if (state_ == State::kWaiting) {  // no answer in time
    if (attempts_ >= timing_.max_attempts) {
      state_ = State::kFailed;
      step.failure = "no answer to " + commands_[index_] + " after " + std::to_string(attempts_) +
                     " attempts; is it an XPLR-AOA anchor?";
      return step;
    }
  }
  if (commands_.empty()) {
    state_ = State::kEnabled;
    return step;
  }
  ++attempts_;
  return send(0, now_s);
}

AtEnabler::Step AtEnabler::on_line(AtLine kind, std::string_view line, double now_s) {
  Step step;
  if (kind == AtLine::kStartup) {
    if (state_ == State::kClosed) return step;
    step.info = "anchor restarted (+STARTUP); enabling its events again";
    on_open(now_s);
    return step;
  }
  if (state_ != State::kWaiting) return step;
  switch (kind) {
    case AtLine::kOk:
      if (index_ + 1 < commands_.size()) {
        Step next = send(index_ + 1, now_s);
        return next;
      }
      state_ = State::kEnabled;
      step.info = "+UUDF events enabled";
      return step;
    case AtLine::kError:
      state_ = State::kFailed;
      step.failure = "the anchor answered " + printable(line) + " to " + commands_[index_];
      return step;
    case AtLine::kResponse:
      step.info = "the anchor says " + printable(line);
      return step;
    case AtLine::kEcho:
    case AtLine::kStartup:
      break;
  }
  return step;
}

}  // namespace ips::ble_aoa
