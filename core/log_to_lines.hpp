#pragma once
// A driver's encoder run over an LCM log: one text line on stdout per message of one channel, so
// that recorded or simulated data can go back through the driver's own parser
// (`ips-uwb-can --to-candump`, `ips-uwb-tdoa-anchors --to-records`). A message that cannot be
// written is skipped, counted, and the first reason named.
#include <csignal>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <functional>
#include <spdlog/spdlog.h>
#include <string>

#include "core/cli.hpp"
#include "core/log_input.hpp"
#include "core/node.hpp"
#include "core/text_escape.hpp"

namespace ips {

// `encode` turns one message into its line (without the newline) and returns true, or returns
// false with the reason in `why`. `unit` names a line in messages, e.g. "candump line". Returns
// the exit status: 0; 1 when the log cannot be read, stdout cannot be written, or the channel had
// messages and none could be written.
template <class Msg>
int write_log_as_lines(const std::string& program, const std::string& path,
                       const std::string& channel, const std::string& unit,
                       const std::function<bool(const Msg&, std::string& line, std::string& why)>& encode) {
  std::signal(SIGPIPE, SIG_IGN);  // `| head`: a write error, reported, not a silent death
  auto in = LogInput::open(program, path);
  if (!in) return 1;
  int64_t messages = 0, written = 0, skipped = 0;
  std::string first_skip, line, why;
  while (const LogEvent* e = in->next()) {
    if (e->channel != channel) continue;
    ++messages;
    Msg m;
    why.clear();
    line.clear();
    if (!decode_message(m, e->data, e->size)) {
      why = "does not decode as " + std::string(Msg::getTypeName());
    } else if (encode(m, line, why)) {
      line += '\n';
      if (std::fwrite(line.data(), 1, line.size(), stdout) != line.size()) break;
      ++written;
      continue;
    }
    ++skipped;
    if (first_skip.empty()) first_skip = why;
    spdlog::debug("{}: {}: skipped a {} message: {}", program, path, channel, printable(why));
  }
  if (!in->finish("converted what was read")) return 1;
  if (std::fflush(stdout) != 0 || std::ferror(stdout)) {
    print_fatal(program, "cannot write the " + unit + "s: " + std::strerror(errno));
    return 1;
  }
  if (messages > 0 && written == 0) {
    print_fatal(program, "no " + channel + " message of '" + path + "' could be written as a " +
                             unit + ": " + printable(first_skip));
    return 1;
  }
  if (skipped > 0)
    spdlog::warn("{}: {}: {} of {} {} messages skipped (first: {})", program, path, skipped,
                 messages, channel, printable(first_skip));
  if (messages == 0) spdlog::warn("{}: {}: no {} message in the log", program, path, channel);
  spdlog::info("{}: wrote {} {}s from {} {} messages of {}", program, written, unit, messages,
               channel, path);
  return 0;
}

}  // namespace ips
