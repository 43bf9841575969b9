#include "core/lcm_url.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>

namespace ips {

namespace {
constexpr const char* kLcmDefaultUrl = "udpm://239.255.76.67:7667?ttl=0";

// Runs `fn` with stderr redirected to a temporary file; returns what was written there.
template <class Fn>
std::string capture_stderr(Fn&& fn) {
  std::fflush(stderr);
  FILE* tmp = std::tmpfile();
  if (!tmp) {
    fn();
    return {};
  }
  int saved = dup(STDERR_FILENO);
  dup2(fileno(tmp), STDERR_FILENO);
  fn();
  std::fflush(stderr);
  dup2(saved, STDERR_FILENO);
  close(saved);
  std::string text;
  std::rewind(tmp);
  char buf[512];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, tmp)) > 0 && text.size() < 4096) text.append(buf, n);
  std::fclose(tmp);
  // One line: fold newlines.
  std::string folded;
  for (char c : text) {
    if (c == '\n' || c == '\r') {
      if (!folded.empty() && folded.back() != ' ') folded += "; ";
    } else {
      folded += c;
    }
  }
  while (!folded.empty() && (folded.back() == ' ' || folded.back() == ';')) folded.pop_back();
  return folded;
}
}  // namespace

std::string effective_lcm_url(const std::string& url) {
  if (!url.empty()) return url;
  if (const char* env = std::getenv("LCM_DEFAULT_URL"); env && *env) return env;
  return kLcmDefaultUrl;
}

std::unique_ptr<lcm::LCM> open_lcm(const std::string& url) {
  const std::string eff = effective_lcm_url(url);
  std::unique_ptr<lcm::LCM> lc;
  std::string lcm_said = capture_stderr([&] { lc = std::make_unique<lcm::LCM>(eff); });
  if (!lc->good()) {
    std::string hint;
    if (lcm_said.find("multicast route") != std::string::npos) {
      // liblcm's own advice names ifconfig/route; give the iproute2 commands and drop the rest.
      // (liblcm 1.3's "No route to <address>" prints an uninitialised address: drop it too.)
      lcm_said = lcm_said.substr(0, std::min(lcm_said.find("; No route to"),
                                             lcm_said.find("; LCM requires")));
      hint = "this machine has no multicast route; as root: ip link set lo multicast on && ip "
             "route add 224.0.0.0/4 dev lo (docs/networking.md)";
    } else {
      hint = "expected e.g. udpm://239.255.76.67:7667?ttl=0 (docs/networking.md)";
    }
    std::string why = lcm_said.empty() ? "liblcm could not create it" : lcm_said;
    throw LcmOpenError("cannot open LCM URL '" + eff + "': " + why + " (" + hint + ")");
  }
  return lc;
}

}  // namespace ips
