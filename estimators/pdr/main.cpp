// ips-pdr: subscribes to IMU, publishes STEP and POSE_PDR per device (hand-held phone PDR).
// `ips-pdr calibrate --log LOG --distance D` fits the step-length constant from a walk of known
// length (source 002's Weinberg calibration, done on a whole walk).
#include <spdlog/spdlog.h>

#include <cmath>
#include <cstdio>
#include <ips/site_t.hpp>

#include "core/channels.hpp"
#include "core/cli.hpp"
#include "core/drop_reasons.hpp"
#include "core/log_input.hpp"
#include "core/node.hpp"
#include "core/site_source.hpp"
#include "core/tag_filter.hpp"
#include "core/text_escape.hpp"
#include "estimators/pdr/pdr_estimator.hpp"

namespace {

constexpr const char* kProgram = "ips-pdr";
namespace pdr = ips::pdr;

struct CalibrateOptions {
  std::string log;
  double distance_m = 0;
  std::string tag;
};

int calibrate(const ips::CommonOptions& opts, const CalibrateOptions& c) {
  if (!(c.distance_m > 0 && c.distance_m < 1e6)) {
    ips::print_fatal(kProgram, "--distance: expected the walked distance in metres (> 0)");
    return 2;
  }
  std::optional<ips::Site> site;
  if (!opts.site_path.empty()) site = ips::load_site_file(opts.site_path);
  const auto log = ips::LogInput::open(kProgram, c.log);
  if (!log) return 2;
  std::string tag = c.tag;
  double sum_length = 0;
  int steps = 0;
  pdr::PdrEstimator est(
      [&](const ips::step_t& s) {
        if (tag.empty()) tag = s.tag_id;
        if (s.tag_id != tag) return;
        sum_length += s.length_m;
        ++steps;
      },
      [](const ips::pose_t&) {});
  if (site) est.set_site(*site);
  const std::string imu_channel = opts.channel(ips::channel::kImu);
  const std::string site_channel = opts.channel(ips::channel::kSite);
  while (const ips::LogEvent* e = log->next()) {
    if (!site && e->channel == site_channel) {
      ips::site_t m;
      if (ips::decode_message(m, e->data, e->size)) {
        site = ips::site_from_msg(m);
        est.set_site(*site);
      }
    } else if (e->channel == imu_channel) {
      ips::imu_t m;
      if (ips::decode_message(m, e->data, e->size)) est.on_imu(m);
    }
  }
  if (!log->finish("calibrating on what was read")) return 2;
  if (!site) {
    ips::print_fatal(kProgram, "no site: give --site FILE or record SITE in the log");
    return 2;
  }
  if (steps == 0) {
    ips::print_fatal(kProgram, "no step detected in " + ips::printable(c.log) +
                                   (tag.empty() ? "" : " for '" + ips::printable(tag) + "'"));
    return 1;
  }
  const pdr::StepLengthParams& lp = est.params().length;
  const char* model = pdr::step_model_name(lp.model);
  double k = lp.k;
  std::string key = "step_k";
  if (lp.model == pdr::StepModel::kModifiedWeinberg || lp.model == pdr::StepModel::kKang) {
    // sum(K f_i - K2) = D, with f_i = (L_i + K2) / K_old.
    const double sum_f = (sum_length + steps * lp.k2) / lp.k;
    k = (c.distance_m + steps * lp.k2) / sum_f;
  } else if (lp.model == pdr::StepModel::kLevi) {
    ips::print_fatal(kProgram, "the levi model has no single constant to calibrate");
    return 2;
  } else {
    k = lp.k * c.distance_m / sum_length;
  }
  std::printf("%s: %d steps of %s, %.2f m with %s = %.4f (%.2f %% of %.2f m)\n", kProgram, steps,
              ips::printable(tag).c_str(), sum_length, key.c_str(), lp.k,
              100.0 * (sum_length - c.distance_m) / c.distance_m, c.distance_m);
  std::printf("site file, estimators.pdr: {step_model: %s, %s: %.4f}\n", model, key.c_str(), k);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"ips-pdr: pedestrian dead reckoning with a hand-held phone: steps (STEP) and "
               "positions (POSE_PDR) from its IMU (IMU), from the start pose in the site.",
               kProgram};
  ips::CommonOptions opts;
  ips::add_common_options(app, opts, {.tags = true});
  CalibrateOptions cal;
  CLI::App* calib = app.add_subcommand(
      "calibrate", "fit the step-length constant (estimators.pdr.step_k) from a log of a walk "
                   "of known length; prints the site-file line");
  calib->add_option("--log", cal.log, "LCM log of the walk (IMU, and SITE unless --site)")
      ->required();
  calib->add_option("--distance", cal.distance_m, "the distance walked, m")->required();
  calib->add_option("--tag", cal.tag, "device to calibrate (default: the first that steps)");
  calib->fallthrough();
  int rc = 0;
  if (!ips::parse_command_line(app, opts, argc, argv, rc)) return rc;
  if (*calib) return ips::run_reporting_errors(kProgram, [&] { return calibrate(opts, cal); });

  return ips::run_reporting_errors(kProgram, [&] {
    ips::Node node(kProgram, opts);
    // --tags/--shard: other tags' messages skipped before the estimator (core/tag_filter.hpp).
    ips::TagFilter tag_filter(node, opts);
    const std::string step_channel = opts.channel(ips::channel::kStep);
    const std::string pose_channel = opts.channel(ips::channel::kPosePdr);
    pdr::PdrEstimator est([&](const ips::step_t& s) { node.publish(step_channel, s); },
                          [&](const ips::pose_t& p) { node.publish(pose_channel, p); });
    ips::provide_site(node, [&](const ips::Site& site) {
      tag_filter.set_site(site);
      est.set_site(site);
    });
    node.subscribe<ips::imu_t>(
        opts.channel(ips::channel::kImu),
        [&](const ips::imu_t& m, const std::string&) {
          if (tag_filter.pass(m.device_id)) est.on_imu(m);
        });
    // Samples that went into no step, by reason, in HEALTH (drops, last_error) once a second.
    ips::DropHealth drop_health;
    ips::ConsistencyHealth consistency_health;
    std::string heading_unknown;  // est.problems() as said in HEALTH
    node.add_timer(1.0, [&] {
      drop_health.report(node, est.drop_reasons());
      consistency_health.report(node, est.consistency());
      if (est.has_site()) {  // and how many magnetometer heading updates were refused, and why
        const std::string c = est.consistency().problems();
        node.set_consistency((c.empty() ? est.consistency().summary() : c) + "; " +
                             est.mag_summary());
      }
      const std::string problems = est.problems();
      if (problems == heading_unknown) return;
      heading_unknown = problems;
      if (problems.empty())
        node.end_lasting_error("heading");
      else
        node.report_lasting_error("heading", problems);
    });
    return node.run();
  });
}
