// libFuzzer target: ips-site's reading of a site file (tools/site/site_keeper.hpp), the site
// loader and then every estimator's checks of its own section. Any text must give a site or a
// refusal with the previous site kept, never a crash, hang or leak.
#include <cstddef>
#include <cstdint>
#include <string>

#include "tools/site/site_keeper.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using ips::site_tool::SiteOutcome;
  ips::site_tool::SiteKeeper keeper("fuzz.yaml");
  if (keeper.offer_text("name: kept\nanchors: []\n").kind != SiteOutcome::Kind::kFirst)
    __builtin_trap();
  const SiteOutcome o = keeper.offer_text(std::string(reinterpret_cast<const char*>(data), size));
  if (!keeper.has_site()) __builtin_trap();
  if (o.kind == SiteOutcome::Kind::kRejected && (keeper.site().name != "kept" || o.text.empty()))
    __builtin_trap();
  if (o.kind != SiteOutcome::Kind::kRejected) {
    (void)ips::site_tool::describe_site_change(keeper.site(), keeper.site());
    (void)ips::site_to_msg(keeper.site(), 1, "fuzz");
  }
  return 0;
}
