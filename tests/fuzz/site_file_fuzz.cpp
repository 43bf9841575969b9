// libFuzzer target: site files and SITE messages are outside bytes. Parsing must either give a
// site or a ConfigError, never crash, hang or leak.
#include <cstddef>
#include <cstdint>
#include <string>

#include "core/site.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    ips::Site site = ips::parse_site_text(text, "fuzz.yaml");
    // Whatever parsed must survive the SITE round trip and parameter lookups.
    ips::site_t msg = ips::site_to_msg(site, 1, "fuzz");
    ips::Site back = ips::site_from_msg(msg);
    (void)back.estimator_params("uwb_twr").get_double("range_sigma_m", 0.1);
  } catch (const ips::ConfigError&) {
  }
  // The same bytes as an encoded site_t off the bus.
  ips::site_t m;
  if (size <= INT32_MAX && m.decode(data, 0, static_cast<int>(size)) >= 0) {
    try {
      (void)ips::site_from_msg(m);
    } catch (const ips::ConfigError&) {
    }
  }
  return 0;
}
