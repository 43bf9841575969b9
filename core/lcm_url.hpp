#pragma once
// Opening an LCM instance with a clear error instead of liblcm's own stderr chatter.
#include <lcm/lcm-cpp.hpp>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>

namespace ips {

struct LcmOpenError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// The URL in effect: `url` if not empty, else LCM_DEFAULT_URL, else LCM's default.
std::string effective_lcm_url(const std::string& url);

// The kernel receive buffer asked for on a udpm URL that does not say (recv_buf_size=): 4 MiB,
// several seconds of a 50-walker lab (docs/networking.md#loss). The kernel caps it at
// net.core.rmem_max.
inline constexpr int kDefaultRecvBufBytes = 4 << 20;

// `url` with recv_buf_size=`recv_buf_bytes` added when it is a udpm URL that has none (a URL that
// sets it keeps its own). recv_buf_bytes <= 0: `url` unchanged.
std::string lcm_url_with_recv_buf(const std::string& url, int recv_buf_bytes);

// The recv_buf_size a udpm URL asks for, or 0 (none, or not udpm).
int lcm_url_recv_buf(const std::string& url);
// The port of a udpm URL (7667 when it names none), or 0 when it is not udpm.
uint16_t lcm_url_udpm_port(const std::string& url);
// The multicast group of a udpm URL (LCM's 239.255.76.67 when it names none), or "" when it is
// not udpm.
std::string lcm_url_udpm_group(const std::string& url);

// Opens LCM on `url` (empty: default) with recv_buf_size added as lcm_url_with_recv_buf() does.
// Throws LcmOpenError with one line saying which URL failed and why (liblcm's own messages
// folded in), and what to try.
std::unique_ptr<lcm::LCM> open_lcm(const std::string& url,
                                   int recv_buf_bytes = kDefaultRecvBufBytes);

}  // namespace ips
