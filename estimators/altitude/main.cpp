// ips-altitude: subscribes to BARO, publishes each tag's differential barometric height on
// ALTITUDE. `ips-altitude calibrate --log LOG [--out SITE]` fits the sensors' pressure offsets
// from a capture beside a reference station (003_baro.md section 2.4).
#include <spdlog/spdlog.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <ips/site_t.hpp>

#include "core/channels.hpp"
#include "core/cli.hpp"
#include "core/consistency.hpp"
#include "core/drop_reasons.hpp"
#include "core/device_text.hpp"
#include "core/log_input.hpp"
#include "core/node.hpp"
#include "core/site_source.hpp"
#include "core/tag_filter.hpp"
#include "core/text_escape.hpp"
#include "estimators/altitude/altitude_estimator.hpp"
#include "estimators/altitude/offset_calibration.hpp"

namespace {

constexpr const char* kProgram = "ips-altitude";
namespace alt = ips::altitude;

struct CalibrateOptions {
  std::string log;
  std::string out;
  bool force = false;
  std::vector<std::string> at;
  alt::OffsetCalibrationOptions fit;
};

int usage(const std::string& what) {
  ips::print_fatal(kProgram, what);
  return 2;
}

int calibrate(const ips::CommonOptions& opts, CalibrateOptions c) {
  if (!(c.fit.settle_s >= 0 && c.fit.settle_s <= 86400))
    return usage("--settle: expected 0 to 86400 s");
  if (!(c.fit.span_s >= 0 && c.fit.span_s <= 86400 * 30))
    return usage("--span: expected 0 (to the end) to 2592000 s");
  for (const auto& a : c.at) {
    const auto eq = a.find('=');
    double h = NAN;
    if (eq == std::string::npos || eq == 0 ||
        !ips::parse_decimal(a.substr(eq + 1), h) || !(std::abs(h) <= 10000))
      return usage("--at: expected SENSOR=HEIGHT_M, got '" + ips::printable(a) + "'");
    c.fit.heights_m[a.substr(0, eq)] = h;
  }
  if (!c.out.empty() && !c.force && std::filesystem::exists(c.out))
    return usage("--out: '" + ips::printable(c.out) + "' exists (--force to overwrite)");
  std::optional<ips::Site> site;
  if (!opts.site_path.empty()) site = ips::load_site_file(opts.site_path);
  const auto log = ips::LogInput::open(kProgram, c.log);
  if (!log) return 2;
  const std::string baro_channel = opts.channel(ips::channel::kBaro);
  const std::string site_channel = opts.channel(ips::channel::kSite);
  std::vector<ips::baro_t> readings;
  int64_t undecodable = 0;
  while (const ips::LogEvent* e = log->next()) {
    if (!site && e->channel == site_channel) {
      ips::site_t m;
      if (ips::decode_message(m, e->data, e->size)) site = ips::site_from_msg(m);
    } else if (e->channel == baro_channel) {
      ips::baro_t m;
      if (ips::decode_message(m, e->data, e->size)) {
        readings.push_back(std::move(m));
      } else {
        ++undecodable;
      }
    }
  }
  if (!log->finish("calibrating on what was read")) return 2;
  if (site) {
    const alt::AltitudeParams p = alt::parse_altitude_params(site->estimator_params("altitude"));
    c.fit.humidity_pct = p.humidity_pct;
    c.fit.temperature_c = p.temperature_c;
    c.fit.gravity_mps2 = p.gravity_mps2;
    c.fit.site_offsets_pa = p.offsets_pa;
  }
  alt::OffsetCalibration cal(c.fit);
  if (site) cal.set_site(*site);
  for (const auto& m : readings) cal.on_baro(m);
  std::vector<alt::SensorOffset> offsets;
  try {
    offsets = cal.finish();
  } catch (const alt::OffsetCalibrationError& e) {
    return usage(e.what());
  }
  if (undecodable + cal.dropped() > 0)
    std::fprintf(stderr, "%s: warning: %lld BARO events skipped (undecodable, invalid or out of "
                 "order)\n", kProgram, static_cast<long long>(undecodable + cal.dropped()));
  std::printf("reference %s; the first %.0f s of each sensor discarded (settling)\n",
              ips::printable(cal.reference_id()).c_str(), c.fit.settle_s);
  std::printf("%-12s %8s %15s %10s %10s %12s %14s\n", "sensor", "readings", "window s",
              "offset Pa", "as m", "sigma Pa", "drift Pa/min");
  int fitted = 0;
  for (const auto& o : offsets) {
    if (o.used == 0) {
      std::printf("%-12s %8lld %15s  no reading after settling: not fitted\n",
                  ips::printable(o.sensor_id).c_str(), static_cast<long long>(o.readings), "-");
      continue;
    }
    ++fitted;
    char window[32];
    std::snprintf(window, sizeof window, "%.0f-%.0f", o.window_start_s, o.window_end_s);
    std::printf("%-12s %8lld %15s %10.3f %10.3f %12.3f %14.4f\n",
                ips::printable(o.sensor_id).c_str(), static_cast<long long>(o.used), window,
                o.offset_pa, o.offset_height_m, o.sigma_pa, o.drift_pa_per_min);
    // Still settling: the drift over the window is not small against the noise.
    const double drift_pa = std::abs(o.drift_pa_per_min) * (o.window_end_s - o.window_start_s) / 60;
    if (drift_pa > std::max(0.5, 2 * o.sigma_pa))
      std::printf("  warning: %s drifted %.2f Pa over the window: still settling? (--settle)\n",
                  ips::printable(o.sensor_id).c_str(), drift_pa);
  }
  if (fitted == 0) {
    ips::print_fatal(kProgram, "no sensor could be fitted (no reading after --settle " +
                                   std::to_string(static_cast<int>(c.fit.settle_s)) + " s)");
    return 1;
  }
  std::printf("site file, estimators.altitude.offsets_pa: {");
  bool first = true;
  for (const auto& o : offsets) {
    if (o.used == 0) continue;
    std::printf("%s%s: %.3f", first ? "" : ", ", ips::printable(o.sensor_id).c_str(), o.offset_pa);
    first = false;
  }
  std::printf("}\n");
  if (c.out.empty()) return 0;
  if (!site) return usage("--out needs a site: give --site FILE or record SITE in the log");
  std::string text;
  try {
    text = alt::site_with_offsets(
        *site, offsets,
        {"Calibrated by ips-altitude calibrate from " + ips::printable(c.log) + ": " +
             std::to_string(fitted) + " sensors against reference " +
             ips::printable(cal.reference_id()) + ".",
         "Comments of the input site are not kept."});
  } catch (const ips::ConfigError& e) {
    ips::print_fatal(kProgram, e.what());
    return 1;
  }
  if (std::string error; !ips::write_text_file(c.out, text, error)) {
    ips::print_fatal(kProgram, error);
    return 1;
  }
  std::printf("wrote %s\n", ips::printable(c.out).c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"ips-altitude: each tag's height from differential barometry: its barometer "
               "against a reference station at a known height (BARO), through the "
               "hypsometric equation and a Kalman filter on height and vertical speed; "
               "publishes ALTITUDE (with the floor when the site lists floor heights). "
               "Parameters and sensor offsets: the site's estimators.altitude.",
               kProgram};
  ips::CommonOptions opts;
  ips::add_common_options(app, opts, {.tags = true});
  CalibrateOptions cal;
  CLI::App* calib = app.add_subcommand(
      "calibrate",
      "fit the barometers' pressure offsets (estimators.altitude.offsets_pa) from a log of them "
      "sitting beside a reference station; prints them, and writes the site with --out");
  calib->add_option("--log", cal.log, "LCM log of the capture (BARO, and SITE unless --site)")
      ->required();
  calib->add_option("--reference", cal.fit.reference,
                    "the sensor the others sat beside (default: the log's only reference "
                    "station)");
  calib->add_option("--settle", cal.fit.settle_s,
                    "discard each sensor's first S seconds (thermal settling; 003: 180)")
      ->capture_default_str();
  calib->add_option("--span", cal.fit.span_s,
                    "use S seconds after settling (0: to the end of the log)")
      ->capture_default_str();
  calib->add_option("--at", cal.at,
                    "a sensor that was not beside the reference stood at this height (m, site "
                    "frame); repeatable")
      ->type_name("SENSOR=HEIGHT_M");
  calib->add_option("--out", cal.out, "write the site with the offsets here")
      ->type_name("SITE.yaml");
  calib->add_flag("--force", cal.force, "overwrite --out when it exists");
  calib->fallthrough();
  int rc = 0;
  if (!ips::parse_command_line(app, opts, argc, argv, rc)) return rc;
  if (*calib) return ips::run_reporting_errors(kProgram, [&] { return calibrate(opts, cal); });

  return ips::run_reporting_errors(kProgram, [&] {
    ips::Node node(kProgram, opts);
    // --tags/--shard: other tags' messages skipped before the estimator (core/tag_filter.hpp).
    ips::TagFilter tag_filter(node, opts);
    const std::string out_channel = opts.channel(ips::channel::kAltitude);
    alt::AltitudeEstimator est([&](const ips::altitude_t& a) { node.publish(out_channel, a); });
    ips::provide_site(node, [&](const ips::Site& site) {
      tag_filter.set_site(site);
      est.set_site(site);
    });
    node.subscribe<ips::baro_t>(
        opts.channel(ips::channel::kBaro),
        [&](const ips::baro_t& m, const std::string&) {
          // A reference station serves every tag: it always passes.
          if (m.is_reference || tag_filter.pass(m.sensor_id)) est.on_baro(m);
        });
    // Readings that gave no altitude, by reason, in HEALTH once a second, with the newest
    // problem in words ("no reference barometer heard yet: no altitude for T1").
    ips::DropHealth drop_health;
    // Each sensor's innovations against its assumed noise (core/consistency.hpp).
    ips::ConsistencyHealth consistency_health;
    node.add_timer(1.0, [&] {
      drop_health.report(node, est.drop_reasons(), est.take_problem());
      consistency_health.report(node, est.consistency());
      // Single-barometer mode: said in HEALTH as well as in each altitude_t's source.
      if (est.relative()) {
        const std::string problems = est.consistency().problems();
        const std::string text = problems.empty() ? est.consistency().summary() : problems;
        node.set_consistency("relative heights (no reference station)" +
                             (text.empty() ? std::string() : "; " + text));
      }
    });
    return node.run();
  });
}
