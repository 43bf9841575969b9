#pragma once
// Writes the site with range offsets (and scales) merged in, as ips-uwb-calibrate --out and
// ips-uwb-survey --offsets --out do: site_with_offsets_yaml(), then the file, then one line
// "wrote FILE (N offsets)". An error is one line on stderr; returns the exit status (0, or 1
// when the site cannot be written).
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "core/cli.hpp"
#include "core/text_escape.hpp"
#include "core/yaml_fields.hpp"
#include "estimators/uwb_twr/range_calibration.hpp"

namespace ips::uwb_twr {

inline int write_offsets_site(const char* program, const Site& site,
                              const std::map<std::string, double>& offsets,
                              const std::vector<std::string>& header, const std::string& out_path,
                              const std::map<std::string, double>& scales = {}) {
  std::string text;
  try {
    text = site_with_offsets_yaml(site, offsets, header, scales);
  } catch (const ConfigError& err) {
    print_fatal(program, err.what());
    return 1;
  }
  if (std::string error; !write_text_file(out_path, text, error)) {
    print_fatal(program, error);
    return 1;
  }
  std::printf("wrote %s (%zu offsets)\n", printable(out_path).c_str(), offsets.size());
  return 0;
}

}  // namespace ips::uwb_twr
