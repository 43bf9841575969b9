#include "core/lcm_url.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <optional>

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

namespace {
bool is_udpm(const std::string& url) { return url.rfind("udpm://", 0) == 0; }

// The value of `key` in the URL's query, or nullopt.
std::optional<std::string> query_value(const std::string& url, const std::string& key) {
  const size_t q = url.find('?');
  if (q == std::string::npos) return std::nullopt;
  size_t pos = q + 1;
  while (pos <= url.size()) {
    size_t end = url.find('&', pos);
    if (end == std::string::npos) end = url.size();
    const std::string item = url.substr(pos, end - pos);
    const size_t eq = item.find('=');
    if (item.substr(0, eq) == key) return eq == std::string::npos ? "" : item.substr(eq + 1);
    pos = end + 1;
  }
  return std::nullopt;
}
}  // namespace

std::string lcm_url_with_recv_buf(const std::string& url, int recv_buf_bytes) {
  if (recv_buf_bytes <= 0 || !is_udpm(url) || query_value(url, "recv_buf_size")) return url;
  const char sep = url.find('?') == std::string::npos ? '?' : '&';
  return url + sep + "recv_buf_size=" + std::to_string(recv_buf_bytes);
}

int lcm_url_recv_buf(const std::string& url) {
  if (!is_udpm(url)) return 0;
  const auto v = query_value(url, "recv_buf_size");
  if (!v) return 0;
  return static_cast<int>(std::clamp(std::strtol(v->c_str(), nullptr, 0), 0L, long{INT32_MAX}));
}

namespace {
// A udpm URL's "GROUP[:PORT]" part.
std::string udpm_target(const std::string& url) {
  const size_t q = url.find('?');
  return url.substr(7, q == std::string::npos ? q : q - 7);
}
}  // namespace

std::string lcm_url_udpm_group(const std::string& url) {
  if (!is_udpm(url)) return "";
  const std::string target = udpm_target(url);
  const std::string group = target.substr(0, target.rfind(':'));
  return group.empty() ? "239.255.76.67" : group;
}

uint16_t lcm_url_udpm_port(const std::string& url) {
  if (!is_udpm(url)) return 0;
  const std::string target = udpm_target(url);
  const size_t colon = target.rfind(':');
  if (colon == std::string::npos) return 7667;
  const long port = std::strtol(target.c_str() + colon + 1, nullptr, 10);
  return port > 0 && port <= 65535 ? static_cast<uint16_t>(port) : 7667;
}

std::unique_ptr<lcm::LCM> open_lcm(const std::string& url, int recv_buf_bytes) {
  const std::string eff = effective_lcm_url(url);
  const std::string opened = lcm_url_with_recv_buf(eff, recv_buf_bytes);
  std::unique_ptr<lcm::LCM> lc;
  std::string lcm_said = capture_stderr([&] { lc = std::make_unique<lcm::LCM>(opened); });
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
