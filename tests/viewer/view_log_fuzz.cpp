// libFuzzer target: arbitrary bytes as an LCM log shown by ips-view (core/log_reader.hpp ->
// viewer-headless/bus_feed.hpp -> ViewModel), with small bounds so that the tables fill and
// expire. Every message goes through the site_t / health_t / pose_t decoders and the model; then
// the JSON snapshot (with and without trails) and the SVG map are built from whatever was kept.
// Checks that the bounds hold, and that the JSON and SVG never carry a raw '<' from the input:
// a tag, channel, source or site name holding markup must come out escaped.
#include <cstddef>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>

#include "core/log_reader.hpp"
#include "viewer-headless/bus_feed.hpp"
#include "viewer-headless/svg_render.hpp"
#include "viewer-headless/view_model.hpp"

namespace {

void check(bool ok, const char* what) {
  if (!ok) throw std::logic_error(what);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  ips::view::ViewOptions o;
  o.trail_length = 16;
  o.max_tracks = 8;
  o.max_channels = 8;
  o.max_processes = 4;
  o.max_anchors = 64;
  o.expire_s = 0.5;
  ips::view::ViewModel model(o);
  ips::view::BusFeed feed(model, {});
  ips::MemoryLogSource source(std::span<const uint8_t>(data, size));
  ips::LogReader reader(source, 4096);
  ips::utime_t last = 0;
  while (const ips::LogEvent* e = reader.next()) {
    feed.feed(e->channel, e->data, e->size, e->timestamp_us);
    last = e->timestamp_us;
  }
  check(model.tracks().size() <= o.max_tracks, "tracks bound");
  check(model.processes().size() <= o.max_processes, "processes bound");
  check(model.channel_table(last).size() <= o.max_channels, "channels bound");
  check(model.anchors().size() <= o.max_anchors, "anchors bound");
  const std::string json = model.json(last);
  const std::string brief = model.json(last, false);
  check(json.find('<') == std::string::npos && brief.find('<') == std::string::npos,
        "a raw '<' in the JSON");
  ips::view::SvgOptions svg_options;
  const std::string svg = ips::view::render_svg(model, svg_options);
  // Markup is ours only: every element the SVG opens is one render_svg writes.
  for (size_t at = svg.find('<'); at != std::string::npos; at = svg.find('<', at + 1)) {
    static const char* const kTags[] = {"svg",     "/svg",   "title", "/title",    "rect",
                                        "defs",    "/defs",  "clipPath", "/clipPath", "marker",
                                        "/marker", "path",   "g ",    "g>",      "/g>",
                                        "line",    "polyline", "ellipse", "circle", "/circle",
                                        "text",    "/text"};
    bool known = false;
    for (const char* t : kTags)
      if (svg.compare(at + 1, std::char_traits<char>::length(t), t) == 0) known = true;
    check(known, "an element in the SVG that render_svg does not write");
  }
  return 0;
}
