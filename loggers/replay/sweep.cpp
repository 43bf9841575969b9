#include "loggers/replay/sweep.hpp"

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <ips/pose_t.hpp>
#include <ips/site_t.hpp>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>

#include "core/channels.hpp"
#include "core/log_input.hpp"
#include "core/log_writer.hpp"
#include "core/node.hpp"
#include "core/site_edit.hpp"
#include "loggers/eval/evaluation.hpp"
#include "loggers/replay/replayer.hpp"

namespace ips::replay {

namespace {

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> parts;
  size_t start = 0;
  for (;;) {
    const size_t at = s.find(sep, start);
    parts.push_back(s.substr(start, at == std::string::npos ? std::string::npos : at - start));
    if (at == std::string::npos) return parts;
    start = at + 1;
  }
}

bool key_char(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '/';
}

// The log's first SITE message, as a site.
Site site_of_log(const std::string& path, const CommonOptions& channels) {
  const auto in = LogInput::open("ips-replay", path, true);
  if (!in) throw ConfigError("cannot read log '" + path + "'");
  in->hide_progress();
  const std::string site_channel = channels.channel(channel::kSite);
  while (const LogEvent* e = in->next()) {
    if (e->channel != site_channel) continue;
    site_t m;
    if (!decode_message(m, e->data, e->size)) continue;
    try {
      return site_from_msg(m);
    } catch (const ConfigError&) {
      continue;  // the next SITE may be good
    }
  }
  throw ConfigError("'" + path + "' has no SITE message to sweep: give --site FILE");
}

// One configuration on one log: replayed, the metric channel scored against TRUTH.
// With `out_path`, the replay is also written there.
SweepScore score(const SweepOptions& o, const std::string& path, std::shared_ptr<const Site> site,
                 const std::string& out_path) {
  std::unique_ptr<LogWriter> out;
  if (!out_path.empty()) {
    out = std::make_unique<LogWriter>(out_path);
    if (!out->ok()) throw ConfigError(out->error());
  }
  std::atomic<bool> write_failed{false};  // set by the sink: with lanes, on the merging thread
  ReplayOptions ro = o.replay;
  ro.site = std::move(site);
  ro.site_path.clear();
  ro.threads = 1;
  eval::Evaluator ev;
  const std::string truth = o.channels.channel(channel::kTruth);
  pose_t m;
  Replayer host(ro, o.channels, [&](const std::string& ch, int64_t ts, const uint8_t* d, size_t n) {
    if (out && !out->add(ch, ts, d, n)) write_failed = true;
    if (ch != truth && ch != o.channel) return;
    if (!decode_message(m, d, n)) return;
    if (ch == truth)
      ev.add_truth(m);
    else
      ev.add_estimate(ch, m);
  });
  const auto in = LogInput::open("ips-replay", path, true);
  if (!in) throw ConfigError("cannot read log '" + path + "'");
  in->hide_progress();
  while (const LogEvent* e = in->next()) {
    host.process(e->channel, e->timestamp_us, e->data, e->size, true);
    if (write_failed) break;
  }
  host.finish();
  if (out && (write_failed || !out->close()))
    throw ConfigError(out->error() + " (disk full?)");
  SweepScore s;
  for (const eval::ErrorRow& r : ev.rows_by_channel()) {
    if (r.channel != o.channel) continue;
    s.count = r.count;
    s.rmse_h = r.rmse_h;
    s.cep50 = r.cep50();
    s.cep95 = r.cep95();
    s.max_h = r.max_h;
    s.rmse_v = r.count_v > 0 ? r.rmse_v : NAN;
  }
  return s;
}

std::string fixed(double v, int digits) {
  if (!std::isfinite(v)) return "-";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.*f", digits, v);
  return buf;
}

std::string pad(std::string s, size_t width) {
  if (s.size() < width) s.append(width - s.size(), ' ');
  return s;
}

}  // namespace

SweepSetting parse_sweep_setting(const std::string& text) {
  const size_t eq = text.find('=');
  const std::string form = " (e.g. estimators.fuse.range_sigma_m=0.1,0.2)";
  if (eq == std::string::npos || eq == 0)
    throw ConfigError("--set '" + text + "': not KEY=V1,V2,..." + form);
  SweepSetting s;
  s.key = text.substr(0, eq);
  for (const auto& part : split(s.key, '.'))
    if (part.empty() || !std::all_of(part.begin(), part.end(), key_char))
      throw ConfigError("--set '" + text + "': '" + s.key + "' is not a site key" + form);
  for (const auto& v : split(text.substr(eq + 1), ',')) {
    if (v.empty()) throw ConfigError("--set '" + text + "': an empty value" + form);
    s.values.push_back(v);
  }
  return s;
}

std::vector<std::vector<std::string>> sweep_grid(const std::vector<SweepSetting>& settings) {
  std::vector<std::vector<std::string>> grid{{}};
  for (const auto& s : settings) {
    std::vector<std::vector<std::string>> next;
    for (const auto& row : grid)
      for (const auto& v : s.values) {
        next.push_back(row);
        next.back().push_back(v);
      }
    grid = std::move(next);
  }
  return grid;
}

Site site_with_settings(const Site& base, const std::vector<SweepSetting>& settings,
                        const std::vector<std::string>& values) {
  SiteYamlEdit edit(base);
  for (size_t i = 0; i < settings.size(); ++i) {
    std::vector<std::string> path = split(settings[i].key, '.');
    const std::string leaf = path.back();
    path.pop_back();
    YAML::Node map = edit.map_at(path);
    YAML::Node value;
    try {
      value = YAML::Load(values[i]);
    } catch (const YAML::Exception&) {
      value = YAML::Node(values[i]);
    }
    map[leaf] = value;
  }
  return parse_site_text(edit.text({}), "the site with --set");
}

double SweepScore::metric(const std::string& name) const {
  if (!scored()) return NAN;
  if (name == "rmse") return rmse_h;
  if (name == "cep50") return cep50;
  if (name == "cep95") return cep95;
  if (name == "max") return max_h;
  if (name == "rmse_v") return rmse_v;
  return NAN;
}

const std::vector<std::string>& sweep_metrics() {
  static const std::vector<std::string> names = {"rmse", "cep50", "cep95", "max", "rmse_v"};
  return names;
}

std::vector<SweepRow> run_sweep(const SweepOptions& o) {
  // The base site of each log.
  std::vector<Site> bases;
  if (!o.site_path.empty()) {
    bases.assign(o.logs.size(), load_site_file(o.site_path));
  } else {
    for (const auto& path : o.logs) bases.push_back(site_of_log(path, o.channels));
  }
  const auto grid = sweep_grid(o.settings);
  std::vector<SweepRow> rows(grid.size());
  for (size_t c = 0; c < grid.size(); ++c) {
    rows[c].values = grid[c];
    rows[c].logs.resize(o.logs.size());
  }
  // The replays' files, when asked for.
  const auto output = [&](size_t c, size_t l) {
    if (o.out_dir.empty()) return std::string();
    std::string name = "config-" + std::to_string(c + 1);
    if (o.logs.size() > 1) name += "-log-" + std::to_string(l + 1);
    return (std::filesystem::path(o.out_dir) / (name + ".lcm")).string();
  };
  if (!o.out_dir.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(o.out_dir, ec);
    if (ec) throw ConfigError("--out-dir '" + o.out_dir + "': " + ec.message());
    for (size_t c = 0; c < grid.size(); ++c)
      for (size_t l = 0; l < o.logs.size(); ++l) rows[c].outputs.push_back(output(c, l));
  }
  const size_t tasks = grid.size() * o.logs.size();
  std::atomic<size_t> next{0};
  std::mutex mutex;
  size_t done = 0;
  const auto work = [&] {
    for (size_t t; (t = next++) < tasks;) {
      const size_t c = t / o.logs.size(), l = t % o.logs.size();
      std::string error;
      SweepScore s;
      try {
        const auto site =
            std::make_shared<const Site>(site_with_settings(bases[l], o.settings, grid[c]));
        s = score(o, o.logs[l], site, output(c, l));
      } catch (const std::exception& e) {
        error = e.what();
      }
      std::lock_guard<std::mutex> lock(mutex);
      if (!error.empty() && rows[c].error.empty()) rows[c].error = error;
      rows[c].logs[l] = s;
      ++done;
      if (o.progress) o.progress(done, tasks);
    }
  };
  const int jobs = std::max(1, std::min<int>(o.jobs, static_cast<int>(tasks)));
  std::vector<std::thread> threads;
  for (int j = 1; j < jobs; ++j) threads.emplace_back(work);
  work();
  for (auto& t : threads) t.join();
  if (!o.out_dir.empty()) {  // the index, in grid order
    const std::string index = (std::filesystem::path(o.out_dir) / "index.tsv").string();
    std::FILE* f = std::fopen(index.c_str(), "w");
    if (!f) throw ConfigError("--out-dir: cannot write '" + index + "': " + std::strerror(errno));
    std::string text = "file";
    for (const auto& st : o.settings) text += "\t" + st.key;
    text += "\tlog\terror\n";
    for (const auto& r : rows)
      for (size_t l = 0; l < r.outputs.size(); ++l) {
        text += std::filesystem::path(r.outputs[l]).filename().string();
        for (const auto& v : r.values) text += "\t" + v;
        text += "\t" + o.logs[l] + "\t" + r.error + "\n";
      }
    const bool ok = std::fwrite(text.data(), 1, text.size(), f) == text.size();
    if (std::fclose(f) != 0 || !ok) throw ConfigError("--out-dir: cannot write '" + index + "'");
  }
  for (auto& r : rows) {
    double sum = 0;
    for (const auto& s : r.logs) sum += s.metric(o.metric);
    r.mean = r.error.empty() ? sum / static_cast<double>(r.logs.size()) : NAN;
    if (!r.error.empty()) r.logs.clear();
  }
  std::stable_sort(rows.begin(), rows.end(), [](const SweepRow& a, const SweepRow& b) {
    const bool fa = std::isfinite(a.mean), fb = std::isfinite(b.mean);
    if (fa != fb) return fa;
    return fa && a.mean < b.mean;
  });
  return rows;
}

std::string sweep_table(const SweepOptions& o, const std::vector<SweepRow>& rows) {
  std::vector<size_t> widths;
  for (size_t i = 0; i < o.settings.size(); ++i) {
    size_t w = o.settings[i].key.size();
    for (const auto& r : rows) w = std::max(w, r.values[i].size());
    widths.push_back(w + 2);
  }
  const bool one = o.logs.size() == 1;
  std::string out = "ips-replay: " + std::to_string(rows.size()) + " configuration" +
                    (rows.size() == 1 ? "" : "s") + " x " + std::to_string(o.logs.size()) + " log" +
                    (one ? "" : "s") + ", " + o.channel + " against TRUTH, sorted by " + o.metric +
                    (one ? "" : " (mean over the logs)") + ", metres\n";
  std::string head = "  #   ";
  for (size_t i = 0; i < o.settings.size(); ++i) head += pad(o.settings[i].key, widths[i]);
  if (one) {
    head += "n        rmse    cep50   cep95   max     rmse_v";
  } else {
    for (const auto& path : o.logs)
      head += pad(o.metric + " " + std::filesystem::path(path).filename().string(), 12) + "  ";
    head += "mean";
  }
  out += head + "\n";
  for (size_t k = 0; k < rows.size(); ++k) {
    const SweepRow& r = rows[k];
    std::string line = "  " + pad(std::to_string(k + 1), 4);
    for (size_t i = 0; i < r.values.size(); ++i) line += pad(r.values[i], widths[i]);
    if (!r.error.empty()) {
      line += "failed: " + r.error;
    } else if (one) {
      const SweepScore& s = r.logs.front();
      line += pad(std::to_string(s.count), 9) + pad(fixed(s.scored() ? s.rmse_h : NAN, 3), 8) +
              pad(fixed(s.scored() ? s.cep50 : NAN, 3), 8) +
              pad(fixed(s.scored() ? s.cep95 : NAN, 3), 8) +
              pad(fixed(s.scored() ? s.max_h : NAN, 3), 8) + fixed(s.rmse_v, 3);
    } else {
      for (const auto& s : r.logs) line += pad(fixed(s.metric(o.metric), 3), 14);
      line += fixed(r.mean, 3);
    }
    out += line + "\n";
  }
  return out;
}

std::string sweep_json(const SweepOptions& o, const std::vector<SweepRow>& rows) {
  using nlohmann::json;
  const auto num = [](double v) { return std::isfinite(v) ? json(v) : json(nullptr); };
  json j;
  j["channel"] = o.channel;
  j["metric"] = o.metric;
  j["logs"] = o.logs;
  j["settings"] = json::array();
  for (const auto& s : o.settings) j["settings"].push_back(s.key);
  j["rows"] = json::array();
  for (const auto& r : rows) {
    json row;
    json values = json::object();
    for (size_t i = 0; i < r.values.size(); ++i) values[o.settings[i].key] = r.values[i];
    row["values"] = values;
    row["mean"] = num(r.mean);
    if (!r.error.empty()) row["error"] = r.error;
    if (!r.outputs.empty()) row["outputs"] = r.outputs;
    row["logs"] = json::array();
    for (size_t l = 0; l < r.logs.size(); ++l) {
      const SweepScore& s = r.logs[l];
      row["logs"].push_back({{"log", o.logs[l]},
                             {"count", s.count},
                             {"rmse", num(s.metric("rmse"))},
                             {"cep50", num(s.metric("cep50"))},
                             {"cep95", num(s.metric("cep95"))},
                             {"max", num(s.metric("max"))},
                             {"rmse_v", num(s.metric("rmse_v"))}});
    }
    j["rows"].push_back(row);
  }
  return j.dump(2) + "\n";
}

}  // namespace ips::replay
