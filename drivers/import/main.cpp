// ips-import: recorded files -> messages, a driver without a device. Subcommands:
//   ranges F...   two-way ranges (one file per anchor or one for all) -> uwb_range_t on UWB_RANGE,
//                 and the exchanges' raw timestamps when the rows have them -> uwb_twr_timestamps_t
//                 on UWB_TWR_RAW
//   poses F       positions (truth, or an outside estimator's output) -> pose_t on --channel
//   tdoa F...     pairwise TDoA (Loco/Crazyflie, the UTIL dataset) -> uwb_tdoa_t on UWB_TDOA
//   site FILE     a site file -> site_t on SITE at the head of a log and every S s
// Every path reads its files whole, sorts the messages by time and writes them to a log (--out),
// into an existing log (--into), or onto the bus (as fast as possible, or paced with --speed).
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <ips/pose_t.hpp>
#include <ips/site_t.hpp>
#include <ips/uwb_range_t.hpp>
#include <ips/uwb_tdoa_t.hpp>
#include <ips/uwb_twr_timestamps_t.hpp>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "core/channels.hpp"
#include "core/cli.hpp"
#include "core/device_text.hpp"
#include "core/import_output.hpp"
#include "core/log_input.hpp"
#include "core/node.hpp"
#include "core/site.hpp"
#include "core/text_escape.hpp"
#include "drivers/import/pose_rows.hpp"
#include "drivers/import/range_rows.hpp"
#include "drivers/import/site_rows.hpp"
#include "drivers/import/tdoa_rows.hpp"
#include "loggers/eval/dwell_file.hpp"

namespace {

constexpr const char* kProgram = "ips-import";
constexpr int kImportFailed = 1;  // nothing silent: an import that made nothing, or rejected most
constexpr int kUsage = 2;         // a bad command line or an unreadable file

// The flags every subcommand shares (same flag, same meaning as in the drivers' file modes).
struct InputFlags {
  std::string separator, columns, header = "auto", time_unit, file_start, unit, tag, row_tag;
  double rate = 0;
  std::string out, into, channel;
  double speed = 0;
};

void add_input_flags(CLI::App& sub, InputFlags& f) {
  sub.add_option("--separator", f.separator, ", | ; | tab | space (default: detected)");
  sub.add_option("--columns", f.columns,
                 "positional column names, '-' skips (default: by header names)");
  sub.add_option("--header", f.header, "auto | none | yes")->capture_default_str();
  sub.add_option("--time-unit", f.time_unit,
                 "s | ms | us | ns (default: guessed from the magnitude of epoch times, else s)");
  sub.add_option("--file-start", f.file_start,
                 "Unix time (s) or ISO-8601 of the first row, for relative times");
  sub.add_option("--rate", f.rate, "rows have no time: row k at file-start + k/HZ")
      ->check(CLI::Range(1e-6, 1e6));
  sub.add_option("--row-tag", f.row_tag,
                 "take only lines whose first field is this (tagged lines, e.g. range2); the tag "
                 "is column 0");
  sub.add_option("--unit", f.unit, "length unit of the file: m (default), cm, mm, ft, in");
  sub.add_option("--tag", f.tag, "tag id for a file without a tag column");
  sub.add_option("--out", f.out, "write an LCM log (overwritten) instead of publishing");
  sub.add_option("--into", f.into,
                 "merge into this existing log by time (written to --out, or LOG is replaced "
                 "safely: temp file + rename)");
  sub.add_option("--speed", f.speed,
                 "on the bus: pace by the files' times, X times real time (default: as fast as "
                 "possible)")
      ->check(CLI::Range(0.0, 1e6));
}

// The options of the reader from the flags; the error line when a flag is wrong.
std::string reader_options(const InputFlags& f, ips::table::ReadOptions& read,
                           ips::import::TimeOptions& time, ips::table::UnitScale& unit) {
  if (!f.separator.empty()) {
    read.separator = ips::table::separator_from_name(f.separator);
    if (!read.separator) return "--separator: expected , ; tab or space, got '" + ips::printable(f.separator) + "'";
  }
  if (f.header == "none") read.header = ips::table::HeaderMode::kNone;
  else if (f.header == "yes") read.header = ips::table::HeaderMode::kPresent;
  else if (f.header != "auto") return "--header: expected auto, none or yes";
  read.row_tag = f.row_tag;
  if (!f.time_unit.empty()) {
    time.unit = ips::table::time_unit_from_name(f.time_unit);
    if (!time.unit) return "--time-unit: expected s, ms, us or ns, got '" + ips::printable(f.time_unit) + "'";
  }
  if (!f.file_start.empty()) {
    int64_t us = 0;
    if (!ips::import::parse_start_time(f.file_start, us))
      return "--file-start: expected a Unix time in s or ISO-8601, got '" + ips::printable(f.file_start) + "'";
    time.file_start_us = us;
  }
  time.rate_hz = f.rate;
  if (!f.unit.empty()) {
    const auto u = ips::table::parse_unit(f.unit, ips::table::Quantity::kLength);
    if (!u) return "--unit: expected one of " + std::string(ips::table::unit_names(ips::table::Quantity::kLength)) + ", got '" + ips::printable(f.unit) + "'";
    unit = *u;
  }
  if (!f.tag.empty() && !ips::valid_device_id(f.tag))
    return "--tag: '" + ips::printable(f.tag) + "' is not 1 to 32 of A-Za-z0-9_.:-";
  if (!f.out.empty() && !f.into.empty() && f.out == f.into)
    return "--out and --into are the same file: leave --out out to replace the log in place";
  return "";
}

// The whole file, or nullopt after an error line.
std::optional<std::string> read_file(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    ips::print_fatal(kProgram, "cannot read '" + ips::printable(path) + "': " +
                                   (std::filesystem::exists(path, ec) ? "not a regular file"
                                                                      : "no such file"));
    return std::nullopt;
  }
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  if (!in.good() && !in.eof()) {
    ips::print_fatal(kProgram, "cannot read '" + ips::printable(path) + "'");
    return std::nullopt;
  }
  return s.str();
}

void summary(const std::string& name, const ips::table::ImportTally& t, const std::string& what,
             const std::string& time_unit, int64_t first, int64_t last, const std::string& columns) {
  std::string line = name + ": " + std::to_string(t.rows) + " rows, " + std::to_string(t.messages) +
                     " " + what + ", " + std::to_string(t.bad) + " rejected";
  if (t.bad > 0)
    line += " (first: line " + std::to_string(t.first_bad_line) + ": " + t.first_bad_reason + ")";
  line += "; columns " + columns + "; time " + time_unit;
  if (last >= first && t.messages > 0) {
    char span[64];
    std::snprintf(span, sizeof span, " from %s, %.1f s", ips::utc_text(first).c_str(),
                  static_cast<double>(last - first) * 1e-6);
    line += span;
  }
  std::fprintf(stderr, "%s: %s\n", kProgram, line.c_str());
}

void warn(const std::string& what) { std::fprintf(stderr, "%s: warning: %s\n", kProgram, what.c_str()); }

// SITE messages for `site` at the head of [first, last] and every `every_s`.
void add_site(ips::ImportOutput& out, const ips::Site& site, int64_t first, int64_t last,
              double every_s) {
  for (int64_t t : ips::import::site_times(first, last, every_s))
    out.add(ips::channel::kSite, ips::site_to_msg(site, t, kProgram));
}

// Writes `fresh` (with an optional site) where the flags say: merged into --into, into --out, or
// onto the bus. Returns the exit status.
int deliver(const InputFlags& f, const ips::CommonOptions& opts, ips::ImportOutput& fresh,
            const std::optional<ips::Site>& site, double site_every_s) {
  ips::ImportOutput all;
  int64_t existing = 0, dropped_sites = 0;
  // The events of the log to merge into, then the new messages; SITE goes in first so that at
  // equal times it comes first.
  ips::ImportOutput body;
  // The log's first SITE (kept when no new site replaces it): repeated at the new head when the
  // new messages start before it, so that the log stays self-contained.
  std::vector<uint8_t> first_site;
  int64_t first_site_utime = 0;
  if (!f.into.empty()) {
    const auto in = ips::LogInput::open(kProgram, f.into);
    if (!in) return kUsage;
    while (const ips::LogEvent* e = in->next()) {
      if (e->channel == ips::channel::kSite) {
        if (site) {
          ++dropped_sites;
          continue;
        }
        if (first_site.empty() || e->timestamp_us < first_site_utime) {
          first_site.assign(e->data, e->data + e->size);
          first_site_utime = e->timestamp_us;
        }
      }
      body.add_encoded(e->channel, e->timestamp_us, e->data, e->size);
      ++existing;
    }
    if (!in->finish("merging what was read")) return kImportFailed;
  }
  if (!first_site.empty() && fresh.size() > 0 && fresh.first_utime() < first_site_utime) {
    ips::site_t head;
    if (head.decode(first_site.data(), 0, static_cast<int>(first_site.size())) > 0) {
      head.utime = fresh.first_utime();
      all.add(ips::channel::kSite, head);
    }
  }
  fresh.for_each([&](const std::string& ch, int64_t t, const std::vector<uint8_t>& b) {
    body.add_encoded(ch, t, b.data(), b.size());
  });
  if (body.size() == 0) {
    ips::print_fatal(kProgram, "nothing to write (the log to merge into is empty)");
    return kImportFailed;
  }
  int64_t sites = 0;
  if (site) {
    const size_t before = static_cast<size_t>(all.size());
    add_site(all, *site, body.first_utime(), body.last_utime(), site_every_s);
    sites = all.size() - static_cast<int64_t>(before);
  }
  body.for_each([&](const std::string& ch, int64_t t, const std::vector<uint8_t>& b) {
    all.add_encoded(ch, t, b.data(), b.size());
  });

  std::string where;
  if (!f.into.empty() || !f.out.empty()) {
    const std::string target = !f.out.empty() ? f.out : f.into;
    std::string path = target;
    if (f.out.empty()) {  // in place: a temp file beside it, then rename over it
      path = target + ".ips-import-" + std::to_string(::getpid()) + ".tmp";
    }
    if (const std::string err = all.write_log(path); !err.empty()) {
      ips::print_fatal(kProgram, err);
      std::error_code ec;
      if (path != target) std::filesystem::remove(path, ec);
      return kUsage;
    }
    if (path != target) {
      std::error_code ec;
      std::filesystem::rename(path, target, ec);
      if (ec) {
        ips::print_fatal(kProgram, "cannot replace '" + ips::printable(target) + "': " + ec.message());
        std::filesystem::remove(path, ec);
        return kUsage;
      }
    }
    where = "to " + ips::printable(target);
  } else {
    return ips::run_reporting_errors(kProgram, [&] {
      ips::Node node(kProgram, opts);
      if (!all.publish(node, f.speed)) {
        warn("stopped before the end");
        return 130;
      }
      std::fprintf(stderr, "%s: published %lld messages (%lld new, %lld SITE)\n", kProgram,
                   static_cast<long long>(all.size()), static_cast<long long>(fresh.size()),
                   static_cast<long long>(sites));
      return 0;
    });
  }
  std::string line = "wrote " + std::to_string(all.size()) + " messages " + where + " (" +
                     std::to_string(fresh.size()) + " new";
  if (sites > 0) line += ", " + std::to_string(sites) + " SITE";
  if (existing > 0) line += ", " + std::to_string(existing) + " from " + ips::printable(f.into);
  if (dropped_sites > 0) line += ", its " + std::to_string(dropped_sites) + " old SITE replaced";
  line += ")";
  std::fprintf(stderr, "%s: %s\n", kProgram, line.c_str());
  return 0;
}

bool valid_channel(const std::string& name) {
  if (ips::channel::valid_channel_name(name)) return true;
  ips::print_fatal(kProgram, "--channel: bad channel name '" + ips::printable(name) +
                                 "' (1 to 63 letters, digits or _)");
  return false;
}

// --- ranges ----------------------------------------------------------------------------------

struct RangeFlags {
  std::vector<std::string> files;
  std::string anchor, site_out, site_name = "imported";
  bool with_site = false;
  double site_every = 5.0;
  std::string range_from = "file", twr_channel = ips::channel::kUwbTwrRaw;
  int counter_bits = 32;
};

// One line on what the timestamp columns of a file gave.
void twr_summary(const std::string& name, const ips::import::TwrTally& t) {
  std::string line = name + ": " + std::to_string(t.exchanges) + " exchanges with timestamps (" +
                     std::to_string(t.ss) + " SS-TWR, " + std::to_string(t.ds) + " DS-TWR)";
  if (t.ss > 0)
    line += "; clock offset from " + std::to_string(t.clock.measured) + " intervals (" +
            std::to_string(t.clock.counter_interval) + " by the counter, " +
            std::to_string(t.clock.host_interval) + " by host time), " +
            std::to_string(t.no_offset) + " exchanges without one yet (range uncorrected)";
  if (t.clock.implausible > 0)
    line += ", " + std::to_string(t.clock.implausible) + " implausible offsets dropped";
  if (t.no_range > 0) line += "; " + std::to_string(t.no_range) + " without a plausible range";
  if (t.bad > 0)
    line += "; " + std::to_string(t.bad) + " rows' timestamps rejected (first: line " +
            std::to_string(t.first_bad_line) + ": " + t.first_bad_reason + ")";
  std::fprintf(stderr, "%s: %s\n", kProgram, line.c_str());
}

int run_ranges(const InputFlags& f, const RangeFlags& r, const ips::CommonOptions& opts) {
  ips::import::RangeOptions o;
  if (const std::string err = reader_options(f, o.read, o.time, o.unit); !err.empty()) {
    ips::print_fatal(kProgram, err);
    return kUsage;
  }
  if (!r.anchor.empty() && !ips::valid_device_id(r.anchor)) {
    ips::print_fatal(kProgram, "--anchor: '" + ips::printable(r.anchor) + "' is not 1 to 32 of A-Za-z0-9_.:-");
    return kUsage;
  }
  if (!valid_channel(f.channel) || !valid_channel(r.twr_channel)) return kUsage;
  if (r.range_from == "timestamps") {
    o.range_from = ips::import::RangeFrom::kTimestamps;
  } else if (r.range_from != "file") {
    ips::print_fatal(kProgram, "--range-from: expected file or timestamps, got '" +
                                   ips::printable(r.range_from) + "'");
    return kUsage;
  }
  o.counter_bits = r.counter_bits;
  o.columns = f.columns;
  o.tag = f.tag;
  o.anchor = r.anchor;
  ips::ImportOutput fresh;
  std::vector<ips::import::AnchorSeen> anchors;
  std::vector<std::string> tags;
  bool positions = false;
  for (const std::string& path : r.files) {
    const auto text = read_file(path);
    if (!text) return kUsage;
    o.source = std::string(kProgram) + ":" + std::filesystem::path(path).filename().string();
    const ips::import::RangeFile file = ips::import::read_ranges(*text, path, o);
    if (!file.error.empty()) {
      ips::print_fatal(kProgram, file.error);
      return kImportFailed;
    }
    int64_t first = 0, last = 0;
    for (size_t i = 0; i < file.ranges.size(); ++i) {
      const int64_t t = file.ranges[i].utime;
      if (i == 0 || t < first) first = t;
      if (i == 0 || t > last) last = t;
      fresh.add(f.channel, file.ranges[i]);
    }
    for (const auto& x : file.exchanges) fresh.add(r.twr_channel, x);
    summary(path, file.tally, "ranges", file.time_unit, first, last, file.columns);
    if (!file.exchanges.empty() || file.twr.bad > 0) twr_summary(path, file.twr);
    if (file.relative_times)
      warn(path + ": the times look relative (before 2001), kept as they are (seconds after "
                  "1970-01-01); give --file-start T to place them");
    ips::import::merge_anchors(anchors, file.anchors);
    positions = positions || !file.anchors.empty();
    for (const std::string& t : file.tags)
      if (std::find(tags.begin(), tags.end(), t) == tags.end()) tags.push_back(t);
  }

  std::optional<ips::Site> site;
  if (r.with_site || !r.site_out.empty()) {
    if (!positions) {
      ips::print_fatal(kProgram,
                       "--with-site/--site-out need the anchors' positions in the rows (ax, ay[, "
                       "az] columns); for a site file use: ips-import site FILE --into LOG");
      return kUsage;
    }
    for (const auto& a : anchors)
      if (a.spread() > 0.01)
        warn("anchor " + a.id + " moves by " + std::to_string(a.spread()) +
             " m in the rows; the site takes its mean position");
    std::vector<std::string> header = {"Anchors as the range rows of " + std::to_string(r.files.size()) +
                                           " file(s) carry them (mean position per anchor),",
                                       "written by ips-import ranges."};
    const std::string yaml = ips::import::site_yaml_from_anchors(r.site_name, anchors, tags, header);
    const int status = ips::run_reporting_errors(kProgram, [&] {
      site = ips::parse_site_text(yaml, "the anchors of the rows");
      return 0;
    });
    if (status != 0) return status;
    if (!r.site_out.empty()) {
      std::ofstream s(r.site_out, std::ios::binary | std::ios::trunc);
      s << yaml;
      s.flush();
      if (!s.good()) {
        ips::print_fatal(kProgram, "cannot write '" + ips::printable(r.site_out) + "'");
        return kUsage;
      }
      std::fprintf(stderr, "%s: wrote the site (%zu anchors) to %s\n", kProgram, anchors.size(),
                   ips::printable(r.site_out).c_str());
    }
    if (!r.with_site) site.reset();
  }
  return deliver(f, opts, fresh, site, r.site_every);
}

// --- tdoa ------------------------------------------------------------------------------------

int run_tdoa(const InputFlags& f, const std::vector<std::string>& files,
             const ips::CommonOptions& opts) {
  ips::import::TdoaOptions o;
  if (const std::string err = reader_options(f, o.read, o.time, o.unit); !err.empty()) {
    ips::print_fatal(kProgram, err);
    return kUsage;
  }
  if (!valid_channel(f.channel)) return kUsage;
  o.columns = f.columns;
  o.tag = f.tag;
  ips::ImportOutput fresh;
  for (const std::string& path : files) {
    const auto text = read_file(path);
    if (!text) return kUsage;
    o.source = std::string(kProgram) + ":" + std::filesystem::path(path).filename().string();
    const ips::import::TdoaFile file = ips::import::read_tdoa(*text, path, o);
    if (!file.error.empty()) {
      ips::print_fatal(kProgram, file.error);
      return kImportFailed;
    }
    int64_t first = 0, last = 0;
    for (size_t i = 0; i < file.pairs.size(); ++i) {
      const int64_t t = file.pairs[i].utime;
      if (i == 0 || t < first) first = t;
      if (i == 0 || t > last) last = t;
      fresh.add(f.channel, file.pairs[i]);
    }
    summary(path, file.tally, "differences", file.time_unit, first, last, file.columns);
    std::string anchors;
    for (const auto& a : file.anchors) anchors += (anchors.empty() ? "" : " ") + a;
    std::fprintf(stderr, "%s: %s: anchors %s", kProgram, ips::printable(path).c_str(),
                 ips::printable(anchors).c_str());
    if (file.other_rows > 0)
      std::fprintf(stderr, "; %lld rows without a difference (other sensors) skipped",
                   static_cast<long long>(file.other_rows));
    std::fprintf(stderr, "\n");
    if (file.relative_times)
      warn(path + ": the times look relative (before 2001), kept as they are (seconds after "
                  "1970-01-01); give --file-start T to place them");
  }
  return deliver(f, opts, fresh, std::nullopt, 0);
}

// --- poses -----------------------------------------------------------------------------------

struct PoseFlags {
  std::string file, heading_unit = "auto", source;
  std::vector<std::string> lever_arms;
  std::vector<double> offset;
  double rotate_deg = 0, z = 0, dwell_rate = 10;
  bool dwell = false;
};

int run_poses(const InputFlags& f, const PoseFlags& p, const ips::CommonOptions& opts) {
  ips::import::PoseOptions o;
  if (const std::string err = reader_options(f, o.read, o.time, o.unit); !err.empty()) {
    ips::print_fatal(kProgram, err);
    return kUsage;
  }
  if (!valid_channel(f.channel)) return kUsage;
  for (const std::string& text : p.lever_arms) {
    ips::import::LeverArm arm;
    if (const std::string err = ips::import::parse_lever_arm(text, arm); !err.empty()) {
      ips::print_fatal(kProgram, "--lever-arm: " + err);
      return kUsage;
    }
    o.lever_arms.push_back(arm);
  }
  if (!p.offset.empty()) {
    if (p.offset.size() < 2 || p.offset.size() > 3) {
      ips::print_fatal(kProgram, "--offset: expected x,y[,z] in m");
      return kUsage;
    }
    for (size_t k = 0; k < p.offset.size(); ++k) o.frame.offset[static_cast<int>(k)] = p.offset[k];
  }
  o.frame.rotate_rad = p.rotate_deg * M_PI / 180.0;
  if (p.heading_unit == "deg") o.heading_unit = ips::import::HeadingUnit::kDeg;
  else if (p.heading_unit == "rad") o.heading_unit = ips::import::HeadingUnit::kRad;
  else if (p.heading_unit != "auto") {
    ips::print_fatal(kProgram, "--heading-unit: expected auto, deg or rad");
    return kUsage;
  }
  o.z = p.z;
  o.columns = f.columns;
  o.tag = f.tag;
  const bool truth = f.channel == ips::channel::kTruth;
  o.source = !p.source.empty() ? p.source : truth ? "truth" : "ips-import";
  o.cov = truth ? 0.0 : std::numeric_limits<double>::quiet_NaN();
  if (p.dwell && (f.rate > 0 || !f.file_start.empty() || !f.row_tag.empty() || f.header != "auto")) {
    ips::print_fatal(kProgram, "--dwell reads start and end times from the file: it takes no --rate, "
                               "--file-start, --row-tag or --header");
    return kUsage;
  }
  if (p.dwell && !o.lever_arms.empty()) {
    ips::print_fatal(kProgram, "--dwell takes no --lever-arm (dwell files have no orientation)");
    return kUsage;
  }

  const auto text = read_file(p.file);
  if (!text) return kUsage;
  ips::import::PoseFile file;
  if (p.dwell) {
    ips::eval::DwellFileOptions d;
    d.columns = f.columns;
    d.time_unit = o.time.unit;
    if (!f.unit.empty()) d.unit = o.unit;
    d.separator = o.read.separator;
    file = ips::import::dwell_poses(ips::eval::read_dwell_file(*text, p.file, d), p.dwell_rate, o);
  } else {
    file = ips::import::read_poses(*text, p.file, o);
  }
  if (!file.error.empty()) {
    ips::print_fatal(kProgram, file.error);
    return kImportFailed;
  }
  ips::ImportOutput fresh;
  for (const auto& m : file.poses) fresh.add(f.channel, m);
  summary(p.file, file.tally, std::string("poses") + (p.dwell ? " (dwell intervals)" : ""),
          file.time_unit, fresh.first_utime(), fresh.last_utime(), file.columns);
  if (file.relative_times)
    warn(p.file + ": the times look relative (before 2001), kept as they are (seconds after "
                  "1970-01-01); give --file-start T to place them");
  if (file.planar)
    warn(p.file + ": no z column: z = " + std::to_string(o.z) + " m (--z), poses marked 2D");
  return deliver(f, opts, fresh, std::nullopt, 0);
}

// --- site ------------------------------------------------------------------------------------

int run_site(const InputFlags& f, const std::string& site_path, double every_s,
             const ips::CommonOptions& opts) {
  if (f.into.empty()) {
    ips::print_fatal(kProgram, "site: --into LOG is required (the log the site goes into)");
    return kUsage;
  }
  std::optional<ips::Site> site;
  const int status = ips::run_reporting_errors(kProgram, [&] {
    site = ips::load_site_file(site_path);
    return 0;
  });
  if (status != 0) return status;
  ips::ImportOutput none;
  return deliver(f, opts, none, site, every_s);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"ips-import: recorded files -> messages (a driver without a device): two-way "
               "ranges, pairwise TDoA, positions (truth or another system's estimates), and a site "
               "written into a log. Output is sorted by time and depends only on the files.",
               kProgram};
  app.require_subcommand(1);
  app.fallthrough();  // --lcm-url and --log-level after the subcommand too
  ips::CommonOptions opts;
  ips::add_common_options(app, opts, {.lcm = true, .site = false, .channels = false});

  InputFlags ranges_flags, poses_flags, site_flags;
  RangeFlags rf;
  ranges_flags.channel = ips::channel::kUwbRange;
  auto* ranges = app.add_subcommand(
      "ranges", "recorded two-way ranges -> uwb_range_t on UWB_RANGE (several files are merged "
                "in time order)");
  ranges->add_option("FILES", rf.files, "range files (one per anchor, or one for all)")->required();
  add_input_flags(*ranges, ranges_flags);
  ranges->add_option("--anchor", rf.anchor, "anchor id for a file without an anchor column");
  ranges->add_option("--channel", ranges_flags.channel, "output channel")->capture_default_str();
  ranges->add_option("--site-out", rf.site_out,
                     "write a site file with the anchors the rows carry (mean positions)");
  ranges->add_flag("--with-site", rf.with_site,
                   "put a SITE with those anchors at the head of the output and every --site-every s");
  ranges->add_option("--site-every", rf.site_every, "SITE period, s (0: only at the head)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1e6));
  ranges->add_option("--site-name", rf.site_name, "the site's name")->capture_default_str();
  ranges->add_option("--range-from", rf.range_from,
                     "file: UWB_RANGE carries the file's range column; timestamps: the range "
                     "computed from the exchange's raw timestamps (SS-TWR with the clock offset "
                     "measured across exchanges, or DS-TWR); rows without one are rejected")
      ->capture_default_str();
  ranges->add_option("--counter-bits", rf.counter_bits,
                     "width of the counter the timestamps are read modulo: 32 when the source "
                     "keeps the low word of a DW1000's 40-bit counter, else 40")
      ->capture_default_str()
      ->check(CLI::Range(16, 62));
  ranges->add_option("--twr-channel", rf.twr_channel,
                     "channel of the exchanges' raw timestamps (uwb_twr_timestamps_t)")
      ->capture_default_str();

  PoseFlags pf;
  auto* poses = app.add_subcommand(
      "poses", "recorded positions -> pose_t on --channel (TRUTH, or POSE_* for another "
               "system's estimates)");
  poses->add_option("FILE", pf.file, "positions file, or dwell intervals with --dwell")->required();
  add_input_flags(*poses, poses_flags);
  poses->add_option("--channel", poses_flags.channel, "output channel: TRUTH or POSE_...")->required();
  poses->add_option("--lever-arm", pf.lever_arms,
                    "TAG=x,y,z: a tag on the rigid body, m in the body frame (x forward, y left, "
                    "z up); repeatable; needs a quaternion or heading column")
      ->type_name("TAG=x,y,z");
  poses->add_option("--offset", pf.offset, "x,y[,z]: added after --rotate-deg (m)")
      ->delimiter(',')
      ->type_name("x,y[,z]");
  poses->add_option("--rotate-deg", pf.rotate_deg,
                    "rotate the file's frame about z by A degrees (counter-clockwise) into the "
                    "site frame: p_site = Rz(A) p + offset");
  poses->add_option("--heading-unit", pf.heading_unit,
                    "auto (deg when the header says deg, else rad), deg or rad")
      ->capture_default_str();
  poses->add_option("--z", pf.z, "height when the file has no z column, m")->capture_default_str();
  poses->add_option("--source", pf.source, "pose_t.source (default: truth on TRUTH, else ips-import)");
  poses->add_flag("--dwell", pf.dwell,
                  "the file is dwell intervals (start, end, x, y[, z][, tag], as ips-eval --dwell "
                  "reads): a pose every 1/--dwell-rate s through each interval");
  poses->add_option("--dwell-rate", pf.dwell_rate, "poses per second in a dwell interval")
      ->capture_default_str()
      ->check(CLI::Range(0.01, 1000.0));

  InputFlags tdoa_flags;
  std::vector<std::string> tdoa_files;
  tdoa_flags.channel = "UWB_TDOA";  // docs/channels.md
  auto* tdoa = app.add_subcommand(
      "tdoa", "recorded pairwise TDoA (Loco-style: Crazyflie TDoA2/TDoA3, the UTIL dataset) -> "
              "uwb_tdoa_t on UWB_TDOA; rows of time, anchor_a, anchor_b, diff = distance to b - "
              "distance to a [, sigma]");
  tdoa->add_option("FILES", tdoa_files, "TDoA files (merged in time order)")->required();
  add_input_flags(*tdoa, tdoa_flags);
  tdoa->add_option("--channel", tdoa_flags.channel, "output channel")->capture_default_str();
  tdoa->footer(
      "Columns (--columns, '-' skips): t, a, b, diff, sigma, quality, seq, tag; by default by the "
      "header's names, else t,a,b,diff. The UTIL dataset's flight CSVs (t_tdoa, idA, idB, "
      "tdoa_meas, and other sensors' columns) are read by their header; their other sensors' "
      "rows are skipped. Give --tag when the file has no tag column.");

  std::string site_path;
  double site_every = 5.0;
  auto* site = app.add_subcommand(
      "site", "a site file -> SITE at the head of a log and every --every s by the log's times, "
              "so the log is self-contained");
  site->add_option("FILE", site_path, "site file (YAML)")->required();
  site->add_option("--into", site_flags.into, "the log (replaced in place unless --out)")->required();
  site->add_option("--out", site_flags.out, "write the result to this new log instead");
  site->add_option("--every", site_every, "SITE period, s (0: only at the head)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1e6));

  int rc = 0;
  if (!ips::parse_command_line(app, opts, argc, argv, rc)) return rc;
  if (ranges->parsed()) return run_ranges(ranges_flags, rf, opts);
  if (poses->parsed()) return run_poses(poses_flags, pf, opts);
  if (tdoa->parsed()) return run_tdoa(tdoa_flags, tdoa_files, opts);
  if (!site_flags.out.empty() && site_flags.out == site_flags.into) {
    ips::print_fatal(kProgram, "--out and --into are the same file: leave --out out to replace the log in place");
    return kUsage;
  }
  return run_site(site_flags, site_path, site_every, opts);
}
