#pragma once
// ips-replay --set: a grid of site settings, each configuration replayed through every hosted
// estimator and scored against TRUTH as ips-eval scores it, the configurations run side by side
// on the cores; one row per configuration, sorted by a chosen metric.
#include <cstddef>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/cli.hpp"
#include "core/site.hpp"
#include "loggers/replay/replay_host.hpp"

namespace ips::replay {

// One --set: a site key ("estimators.fuse.range_sigma_m") and the values to try ("0.1", "0.2").
struct SweepSetting {
  std::string key;
  std::vector<std::string> values;
};
// "estimators.fuse.range_sigma_m=0.1,0.2,0.3"; ConfigError on a bad form.
SweepSetting parse_sweep_setting(const std::string& text);

// The grid: every combination of the settings' values, the first setting varying slowest.
std::vector<std::vector<std::string>> sweep_grid(const std::vector<SweepSetting>& settings);

// `base` with each key set to its value (YAML scalars: numbers, true/false, text); ConfigError
// when a key's path runs through something that is not a map, or the result is not a valid site.
Site site_with_settings(const Site& base, const std::vector<SweepSetting>& settings,
                        const std::vector<std::string>& values);

// The statistics ips-eval gives, for the metric channel pooled over its tags.
struct SweepScore {
  size_t count = 0;  // estimates scored
  double rmse_h = 0, cep50 = 0, cep95 = 0, max_h = 0, rmse_v = 0;
  bool scored() const { return count > 0; }
  // The metric by name (rmse, cep50, cep95, max, rmse_v); NaN for an unknown name or no score.
  double metric(const std::string& name) const;
};

struct SweepRow {
  std::vector<std::string> values;  // one per setting
  std::vector<SweepScore> logs;     // one per log
  std::vector<std::string> outputs;  // with SweepOptions::out_dir: the replays written, per log
  std::string error;                // the configuration failed: why (then logs is empty)
  double mean = 0;                  // the metric averaged over the logs (NaN when not scored)
};

struct SweepOptions {
  std::vector<std::string> logs;
  std::vector<SweepSetting> settings;
  std::string site_path;  // the base site; else each log's first SITE message
  std::string channel = "POSE_FUSED";
  std::string metric = "rmse";
  int jobs = 1;
  ReplayOptions replay;  // only, zones_pose_channel, keep (site and threads are the sweep's)
  CommonOptions channels;
  // Also write each configuration's replay (what `ips-replay LOG --out` writes) into this
  // directory, made when missing: config-<n>.lcm, or config-<n>-log-<k>.lcm with several logs
  // (n and k from 1, in grid and --set order), and index.tsv naming each file's settings and log.
  std::string out_dir;
  // Called after each configuration finishes (from a worker thread, serialised): done, total.
  std::function<void(size_t, size_t)> progress;
};

// The metric names --sort takes.
const std::vector<std::string>& sweep_metrics();

// Runs the grid; rows sorted by `metric` (smaller first; failed and unscored rows last). Throws
// ConfigError when a log has no site and none is given, or a log cannot be read.
std::vector<SweepRow> run_sweep(const SweepOptions& o);

// The table, as text (one row per configuration) and as JSON.
std::string sweep_table(const SweepOptions& o, const std::vector<SweepRow>& rows);
std::string sweep_json(const SweepOptions& o, const std::vector<SweepRow>& rows);

}  // namespace ips::replay
