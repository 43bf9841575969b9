#pragma once
// Which build this is: the project version, `git describe` of the source tree it was built from
// and the CMake build type. Printed by every program's --version and carried in each health_t,
// so that a log says which build made it. Only core/version.cpp sees the generated header, so a
// new commit recompiles that one file (and relinks).
#include <string>

namespace ips {

struct BuildVersion {
  std::string version;     // project version, e.g. "0.1.0" (CMakeLists.txt project())
  std::string git;         // `git describe --always --dirty` of the tree, e.g.
                           // "v0.1.0-123-gabcdef123456-dirty"; "unknown" without git
  std::string build_type;  // CMAKE_BUILD_TYPE, e.g. "Release"
};

BuildVersion build_version();

// "0.1.0 (git v0.1.0-123-gabcdef123456-dirty, Release)".
std::string version_text();

// What --version prints: "<program> " + version_text().
std::string version_line(const std::string& program);

}  // namespace ips
