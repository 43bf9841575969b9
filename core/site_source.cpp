#include "core/site_source.hpp"

#include <ips/site_t.hpp>
#include <memory>
#include <spdlog/spdlog.h>

#include "core/channels.hpp"
#include "core/text_escape.hpp"

namespace ips {

void provide_site(Node& node, std::function<void(const Site&)> on_site) {
  if (!node.options().site_path.empty()) {
    on_site(load_site_file(node.options().site_path));
    return;
  }
  // Until a site arrives the process is up but cannot do its job: say so in health_t.
  node.set_state(health_t::STATE_STARTING);
  spdlog::info("{}: no --site given, waiting for a SITE message on {}", node.name(),
               node.options().channel(channel::kSite));
  auto last_text = std::make_shared<std::string>();
  node.subscribe<site_t>(node.options().channel(channel::kSite),
                         [&node, last_text, on_site](const site_t& msg, const std::string&) {
                           if (msg.site_yaml == *last_text) return;
                           try {
                             Site site = site_from_msg(msg);
                             *last_text = msg.site_yaml;
                             spdlog::info("{}: site '{}' from {} ({} anchors)", node.name(),
                                          printable(site.name), printable(msg.source),
                                          site.anchors.size());
                             on_site(site);
                             node.set_state(health_t::STATE_OK);
                           } catch (const SiteError& e) {
                             ++node.counters().parse_errors;
                             node.report_error(e.what());
                           }
                         });
}

}  // namespace ips
