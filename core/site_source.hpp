#pragma once
// Where a process gets its site: the --site file (errors stop the process at start-up), or else
// the first SITE message on the bus (and any later one that differs).
#include <functional>

#include "core/node.hpp"
#include "core/site.hpp"

namespace ips {

// Calls `on_site` now when --site was given (throws SiteError on a bad file), otherwise from the
// SITE channel whenever a site arrives whose text differs from the last one.
void provide_site(Node& node, std::function<void(const Site&)> on_site);

}  // namespace ips
