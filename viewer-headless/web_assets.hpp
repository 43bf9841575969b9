#pragma once
// The live page's files (viewer-headless/web/), compiled into ips-view by embed_assets.cmake.
#include <span>
#include <string_view>

namespace ips::view {

struct WebAsset {
  std::string_view path;  // URL path: "/" for index.html, "/view.js", ...
  std::string_view content_type;
  std::string_view body;
};

std::span<const WebAsset> web_assets();

}  // namespace ips::view
