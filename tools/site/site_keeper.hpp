#pragma once
// ips-site's core: the site it publishes on SITE, and why the file's present text is not that
// site when it is not. Fed the file's text (or why it could not be read) each time the file may
// have changed; reads no file, clock or socket itself (tools/site/main.cpp does).
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

#include "core/site.hpp"

namespace ips::site_tool {

// A site file larger than this is refused: sites are a few kB, and a SITE message carries the
// whole text in every period.
inline constexpr size_t kMaxSiteFileBytes = 1 << 20;

// What one reading of the file did to the published site.
struct SiteOutcome {
  enum class Kind {
    kFirst,      // the first valid site: publish it
    kReplaced,   // a valid site with a different text: publish it in place of the old one
    kUnchanged,  // the published site's own text again: nothing new to publish
    kRejected,   // not a valid site: the published one (if any) stays; `text` says why
  };
  Kind kind = Kind::kRejected;
  // The file was refused before and is valid now (kReplaced or kUnchanged).
  bool error_cleared = false;
  // kFirst: empty; kReplaced: what changed (describe_site_change); kRejected: the error, with
  // file and line where the loader gives them.
  std::string text;
};

class SiteKeeper {
 public:
  // `origin`: the file's name, as error messages give it.
  explicit SiteKeeper(std::string origin);

  // The file's whole text as just read. Valid means: the site loader takes it (core/site.hpp)
  // and so does every estimator's check of its own section (check_estimator_sections).
  SiteOutcome offer_text(const std::string& text);
  // The file could not be read (missing, unreadable): `error` says why.
  SiteOutcome offer_read_error(const std::string& error);

  bool has_site() const { return site_.has_value(); }
  const Site& site() const { return *site_; }
  // Why the file's present text is not the published site; empty when it is.
  const std::string& error() const { return error_; }
  int64_t replaced() const { return replaced_; }  // sites published after the first
  int64_t rejected() const { return rejected_; }  // readings refused

 private:
  SiteOutcome reject(std::string error);

  std::string origin_;
  std::optional<Site> site_;
  std::string error_;
  int64_t replaced_ = 0;
  int64_t rejected_ = 0;
};

// What differs from `before` to `after`, one clause per thing, for the log: "anchor A2 moved
// 0.10 m to [10.1, 0, 2.4]; tag T1 height_m 1.2 -> 1.25; estimators.uwb_twr changed". Only
// comments or layout when the two differ in nothing the site holds.
std::string describe_site_change(const Site& before, const Site& after);

// Runs every estimator's own checks of the site as it runs them when it takes a site (its
// `estimators.<name>` section, and the anchors that section names): uwb_twr, uwb_tdoa, aoa, pdr,
// ins, altitude and fuse. Throws ConfigError, with file and line, on the first failure.
void check_estimator_sections(const Site& site);

}  // namespace ips::site_tool
