#pragma once
// Where a process gets its site: the --site file (errors stop the process at start-up), or else
// the first SITE message on the bus (and any later one that differs).
#include <functional>
#include <ips/site_t.hpp>
#include <string>

#include "core/node.hpp"
#include "core/site.hpp"

namespace ips {

// Calls `on_site` now when --site was given (throws SiteError on a bad file), otherwise from the
// SITE channel whenever a site arrives whose text differs from the last one. Without --site it
// asks for the site on SITE_REQUEST at start and every second until one arrives, and once it
// holds the bus's site it answers others' requests with the very SITE message it took (the same
// text: nobody's tracks are reset by the answer), at most every kSiteAnswerPeriodS. A process
// with --site does not answer: its file's text may differ from the bus's.
void provide_site(Node& node, std::function<void(const Site&)> on_site);
// The same for an estimator of anchors of `anchor_kind` (uwb, uwb_tdoa, ble_aoa): a site without
// one enabled is said at once (a warning) and in HEALTH as a lasting error
// (missing_anchor_kind()), until a site with them arrives.
void provide_site(Node& node, const std::string& anchor_kind,
                  std::function<void(const Site&)> on_site);

inline constexpr double kSiteRequestPeriodS = 1.0;
inline constexpr double kSiteAnswerPeriodS = 0.5;

// Answers SITE_REQUEST with the site `current()` returns (nullptr: none yet), at most every
// kSiteAnswerPeriodS of host time; for a process that publishes the site itself (ips-sim).
void answer_site_requests(Node& node, std::function<const site_t*()> current);

}  // namespace ips
