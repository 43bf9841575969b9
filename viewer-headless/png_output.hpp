#pragma once
// PNG output of the floor map for reports: the SVG rasterised by rsvg-convert (Debian's
// librsvg2-bin, installed by scripts/install-deps), run as a child process on a temporary file.
#include <string>

namespace ips::view {

// Writes `svg` as a PNG to `out_path` on a white background, scaled by `zoom` (1: the SVG's own
// pixel size). False with `error` set (one line, naming what to install when rsvg-convert is
// missing) when it cannot.
bool svg_to_png(const std::string& svg, const std::string& out_path, double zoom,
                std::string& error);

}  // namespace ips::view
