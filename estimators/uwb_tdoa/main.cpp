// ips-uwb-tdoa: subscribes to UWB_RX (raw receptions) and UWB_TDOA (pairwise differences, as
// Loco-style systems deliver them), publishes POSE_TDOA per tag and CLOCK per anchor.
// `ips-uwb-tdoa rank-masters LOG...` ranks the sync masters of static-tag logs instead (004 §3).
#include <spdlog/spdlog.h>

#include <cmath>
#include <cstdio>
#include <optional>

#include "core/channels.hpp"
#include "core/cli.hpp"
#include "core/drop_reasons.hpp"
#include "core/lcm_url.hpp"
#include "core/log_input.hpp"
#include "core/node.hpp"
#include "core/site_source.hpp"
#include "core/tag_filter.hpp"
#include "core/text_escape.hpp"
#include "estimators/uwb_tdoa/master_ranking.hpp"
#include "estimators/uwb_tdoa/tdoa_estimator.hpp"

namespace {

constexpr const char* kProgram = "ips-uwb-tdoa";

struct RankOptions {
  std::vector<std::string> logs;
  std::string tag;
  std::vector<double> truth;
  double skip_s = 0;
};

int rank_masters(const ips::CommonOptions& opts, const RankOptions& r) {
  if (!opts.lcm_url.empty()) {
    ips::print_fatal(kProgram, "--lcm-url does not apply to rank-masters (it reads logs)");
    return 2;
  }
  std::optional<Eigen::Vector3d> point;
  if (!r.truth.empty()) {
    if (r.truth.size() < 2 || !std::isfinite(r.truth[0]) || !std::isfinite(r.truth[1]) ||
        (r.truth.size() > 2 && !std::isfinite(r.truth[2]))) {
      ips::print_fatal(kProgram, "--truth: expected X,Y or X,Y,Z in metres");
      return 2;
    }
    point = Eigen::Vector3d(r.truth[0], r.truth[1], r.truth.size() > 2 ? r.truth[2] : 0.0);
  }
  if (!(r.skip_s >= 0 && r.skip_s <= 1e6)) {
    ips::print_fatal(kProgram, "--skip: expected seconds in [0, 1e6]");
    return 2;
  }
  ips::uwb_tdoa::MasterRunOptions base;
  base.tag = r.tag;
  base.rx_channel = opts.channel(ips::channel::kUwbRx);
  base.site_channel = opts.channel(ips::channel::kSite);
  base.skip_s = r.skip_s;
  if (!opts.site_path.empty()) base.site = ips::load_site_file(opts.site_path);

  std::vector<ips::uwb_tdoa::MasterSpread> runs;
  for (const auto& path : r.logs) {
    const auto log = ips::LogInput::open(kProgram, path);
    if (!log) return 2;
    ips::uwb_tdoa::MasterRun run(base);
    while (const ips::LogEvent* e = log->next()) run.on_event(e->channel, e->data, e->size);
    if (!log->finish("ranking what was read")) return 2;
    run.finish();
    if (run.bad_sites() > 0)
      std::fprintf(stderr, "%s: warning: %s: %lld SITE message(s) not usable\n", kProgram,
                   ips::printable(path).c_str(), static_cast<long long>(run.bad_sites()));
    ips::uwb_tdoa::MasterSpread s =
        ips::uwb_tdoa::spread_of(run.estimates(), point, r.truth.size() > 2);
    s.label = path;
    s.master = run.master();
    s.tag = run.tag();
    runs.push_back(std::move(s));
  }
  const auto ranked = ips::uwb_tdoa::rank_masters(std::move(runs));
  std::fputs(ips::uwb_tdoa::format_master_ranking(ranked).c_str(), stdout);
  std::printf("(distance %s from %s; best master first: lowest variance, as in 004 §3)\n",
              r.truth.size() > 2 ? "in 3D" : "horizontal",
              point ? "the --truth point" : "the mean of each log's estimates");
  std::fflush(stdout);
  if (ranked.empty() || ranked.front().estimates == 0) {
    ips::print_fatal(
        kProgram, r.tag.empty() ? std::string("no tag position estimated in any log")
                                : "no estimate of tag '" + ips::printable(r.tag) + "' in any log");
    return 1;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "ips-uwb-tdoa: tracks UWB tags from TDoA anchor receptions (UWB_RX): synchronises "
      "the anchor clocks to the sync master (CLOCK) and publishes the tags' positions "
      "with covariance (POSE_TDOA); or from pairwise TDoA as Loco-style systems deliver it "
      "(UWB_TDOA, clocks synchronised upstream).",
      kProgram};
  ips::CommonOptions opts;
  ips::add_common_options(app, opts, {.tags = true});
  RankOptions rank_opts;
  CLI::App* rank = app.add_subcommand(
      "rank-masters",
      "rank the sync masters of logs of a static tag, one log per master, by the variance of the "
      "distance of the estimates from their mean (or the --truth point); best first");
  rank->add_option("LOG", rank_opts.logs, "LCM logs, one per sync master")->required();
  rank->add_option("--tag", rank_opts.tag, "tag to score (default: the first tag estimated)");
  rank->add_option("--truth", rank_opts.truth,
                   "the tag's known position: distances from it instead of from the mean "
                   "(3D distance when Z is given)")
      ->type_name("X,Y[,Z]")
      ->delimiter(',')
      ->expected(2, 3);
  rank->add_option("--skip", rank_opts.skip_s,
                   "seconds after the tag's first estimate that are not scored (default 0)")
      ->type_name("S");
  rank->fallthrough();  // the common options work after the subcommand too
  int rc = 0;
  if (!ips::parse_command_line(app, opts, argc, argv, rc)) return rc;
  if (*rank)
    return ips::run_reporting_errors(kProgram, [&] { return rank_masters(opts, rank_opts); });

  return ips::run_reporting_errors(kProgram, [&] {
    ips::Node node(kProgram, opts);
    // --tags/--shard: other tags' messages skipped before the estimator (core/tag_filter.hpp).
    ips::TagFilter tag_filter(node, opts);
    const std::string pose_channel = opts.channel(ips::channel::kPoseTdoa);
    const std::string clock_channel = opts.channel(ips::channel::kClock);
    ips::uwb_tdoa::TdoaEstimator est(
        [&](const ips::pose_t& p) { node.publish(pose_channel, p); },
        [&](const ips::clock_t& c) { node.publish(clock_channel, c); });
    ips::provide_site(node, "uwb_tdoa", [&](const ips::Site& site) {
      tag_filter.set_site(site);
      est.set_site(site);
    });
    node.subscribe<ips::uwb_rx_t>(
        opts.channel(ips::channel::kUwbRx),
        [&](const ips::uwb_rx_t& m, const std::string&) {
          // A sync master's broadcast serves every tag: it always passes.
          if (m.is_sync || tag_filter.pass(m.sender_id)) est.on_rx(m);
        });
    node.subscribe<ips::uwb_tdoa_t>(
        opts.channel("UWB_TDOA"),  // docs/channels.md
        [&](const ips::uwb_tdoa_t& m, const std::string&) {
          if (tag_filter.pass(m.tag_id)) est.on_pair(m);
        });
    // Reports that gave no pose or clock, by reason, in HEALTH once a second; outliers gated and
    // blinks before the clocks are synchronised are counted without marking the process degraded.
    ips::DropHealth drop_health;
    ips::ConsistencyHealth consistency_health;
    node.add_timer(1.0, [&] {
      const ips::uwb_tdoa::PairStats& ps = est.pair_stats();
      drop_health.report(node, est.drop_reasons(),
                         ps.pairs_in == 0 ? std::string()
                                          : "pairs used " + std::to_string(ps.pairs_used) +
                                                ", gated " + std::to_string(ps.pairs_gated) +
                                                ", tracks lost " + std::to_string(ps.lost));
      consistency_health.report(node, est.consistency());
    });
    return node.run();
  });
}
