#include "core/version.hpp"

// Generated at every build by cmake/version.cmake (rewritten only when its text changes).
#include "ips/version.hpp"

#ifndef IPS_BUILD_TYPE
#error "IPS_BUILD_TYPE is set by core/CMakeLists.txt"
#endif

namespace ips {

BuildVersion build_version() { return {IPS_VERSION, IPS_GIT_DESCRIBE, IPS_BUILD_TYPE}; }

std::string version_text() {
  const BuildVersion v = build_version();
  return v.version + " (git " + v.git + ", " + v.build_type + ")";
}

std::string version_line(const std::string& program) { return program + " " + version_text(); }

}  // namespace ips
