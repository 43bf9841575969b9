#pragma once
// health_t state names as ips-view and ips-deploy status show them.
#include <cstdint>
#include <ips/health_t.hpp>

namespace ips {

// "ok", "degraded", "error", "starting", else "unknown".
inline const char* health_state_name(int8_t state) {
  switch (state) {
    case health_t::STATE_OK:
      return "ok";
    case health_t::STATE_DEGRADED:
      return "degraded";
    case health_t::STATE_ERROR:
      return "error";
    case health_t::STATE_STARTING:
      return "starting";
    default:
      return "unknown";
  }
}

}  // namespace ips
