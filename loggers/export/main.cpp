// ips-export: an LCM log to CSV and JSON lines, one file per channel (docs/programs.md#ips-export).

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <regex>
#include <set>
#include <cstring>

#include "core/cli.hpp"
#include "core/log_input.hpp"
#include "core/text_escape.hpp"
#include "loggers/export/log_export.hpp"

namespace {

namespace fs = std::filesystem;
namespace ex = ips::log_export;
constexpr const char* kProgram = "ips-export";

struct FileCloser {
  void operator()(std::FILE* f) const {
    if (f) std::fclose(f);
  }
};
using File = std::unique_ptr<std::FILE, FileCloser>;

struct ChannelOut {
  std::string type;  // of the first message that decoded; others on the channel are skipped
  std::string stem;
  File csv, jsonl;
  int64_t messages = 0;
  int64_t other_type = 0;
};

// "A (3), B (1)" with names escaped for the terminal.
std::string list_counts(const std::map<std::string, int64_t>& m) {
  std::string out;
  for (const auto& [name, n] : m) {
    if (!out.empty()) out += ", ";
    out += ips::printable(name) + " (" + std::to_string(n) + ")";
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"ips-export: converts an LCM log into one CSV and/or JSON-lines file per channel "
               "(every ips message type; other types are skipped and reported).",
               kProgram};
  ips::CommonOptions opts;
  ips::add_common_options(app, opts, {.lcm = false, .site = false, .channels = false});
  std::string log_path, out_dir, channel_pattern = ".*", format = "both";
  double from_s = NAN, to_s = NAN;
  app.add_option("LOG", log_path, "LCM log file")->required();
  app.add_option("--out", out_dir, "output directory (created if missing; files overwritten)")
      ->required();
  app.add_option("--channels", channel_pattern,
                 "only channels whose whole name matches this regular expression (ECMAScript)")
      ->capture_default_str();
  app.add_option("--from", from_s, "skip events earlier than S seconds after the log's first event")
      ->type_name("S");
  app.add_option("--to", to_s, "skip events later than S seconds after the log's first event")
      ->type_name("S");
  app.add_option("--format", format, "csv, jsonl or both")
      ->check(CLI::IsMember({"csv", "jsonl", "both"}))
      ->capture_default_str();
  int rc = 0;
  if (!ips::parse_command_line(app, opts, argc, argv, rc)) return rc;

  std::regex channel_re;
  try {
    channel_re = std::regex(channel_pattern, std::regex::ECMAScript);
  } catch (const std::regex_error& e) {
    ips::print_fatal(kProgram, "--channels '" + channel_pattern + "': " + e.what());
    return 2;
  }
  if ((!std::isnan(from_s) && !std::isfinite(from_s)) || (!std::isnan(to_s) && !std::isfinite(to_s)) ||
      (std::isfinite(from_s) && std::isfinite(to_s) && to_s < from_s)) {
    ips::print_fatal(kProgram, "--from/--to: expected finite seconds with --from <= --to");
    return 2;
  }
  const bool want_csv = format != "jsonl", want_jsonl = format != "csv";

  const auto log = ips::LogInput::open(kProgram, log_path);
  if (!log) return 2;
  std::error_code ec;

  // The output directory: created, and proven writable with a probe file (permissions alone do
  // not tell, e.g. for root or a read-only mount).
  fs::create_directories(out_dir, ec);
  if (ec || !fs::is_directory(out_dir)) {
    ips::print_fatal(kProgram, "cannot write to output directory '" + out_dir + "': " +
                                   (ec ? ec.message() : std::string("not a directory")));
    return 2;
  }
  {
    const fs::path probe = fs::path(out_dir) / ".ips-export-probe";
    File f(std::fopen(probe.c_str(), "w"));
    if (!f) {
      ips::print_fatal(kProgram, "cannot write to output directory '" + out_dir + "': " +
                                     std::strerror(errno));
      return 2;
    }
    f.reset();
    fs::remove(probe, ec);
  }

  std::map<std::string, ChannelOut> outs;
  std::map<std::string, bool> channel_selected;  // regex result per channel name
  std::map<std::string, int64_t> unknown;        // channel -> messages of no ips type
  std::set<std::string> stems;
  int64_t events = 0, exported = 0, filtered_channel = 0, filtered_time = 0;
  int64_t first_ts = 0;

  auto open_out = [&](const std::string& stem, const char* ext) -> File {
    const fs::path p = fs::path(out_dir) / (stem + ext);
    File f(std::fopen(p.c_str(), "w"));
    if (!f) {
      ips::print_fatal(kProgram, "cannot write '" + p.string() + "': " + std::strerror(errno));
      std::exit(1);
    }
    return f;
  };

  while (const ips::LogEvent* e = log->next()) {
    if (events++ == 0) first_ts = e->timestamp_us;
    auto [sel, inserted] = channel_selected.try_emplace(e->channel, false);
    if (inserted) sel->second = std::regex_match(e->channel, channel_re);
    if (!sel->second) {
      ++filtered_channel;
      continue;
    }
    const double t = static_cast<double>(e->timestamp_us - first_ts) * 1e-6;
    if ((!std::isnan(from_s) && t < from_s) || (!std::isnan(to_s) && t > to_s)) {
      ++filtered_time;
      continue;
    }
    auto msg = ex::decode_any(e->data, e->size);
    if (!msg) {
      ++unknown[e->channel];
      continue;
    }
    ChannelOut& out = outs[e->channel];
    if (out.type.empty()) {
      out.type = msg->type;
      out.stem = ex::file_stem(e->channel);
      for (int n = 2; stems.count(out.stem); ++n)  // two channels, one file name: number them
        out.stem = ex::file_stem(e->channel) + "_" + std::to_string(n);
      stems.insert(out.stem);
      if (want_csv) {
        out.csv = open_out(out.stem, ".csv");
        std::fputs(ex::csv_line(*msg->columns).c_str(), out.csv.get());
      }
      if (want_jsonl) out.jsonl = open_out(out.stem, ".jsonl");
    } else if (out.type != msg->type) {
      ++out.other_type;
      continue;
    }
    if (out.csv)
      for (const auto& row : msg->rows) {
        const std::string line = ex::csv_line(row);
        std::fwrite(line.data(), 1, line.size(), out.csv.get());
      }
    if (out.jsonl) {
      const std::string line = ex::json_line(e->channel, e->timestamp_us, *msg);
      std::fwrite(line.data(), 1, line.size(), out.jsonl.get());
    }
    ++out.messages;
    ++exported;
  }

  for (auto& [channel, out] : outs) {
    for (File* f : {&out.csv, &out.jsonl}) {
      if (*f && (std::fflush(f->get()) != 0 || std::ferror(f->get()))) {
        ips::print_fatal(kProgram, "write to '" + out_dir + "/" + out.stem + "' failed (disk full?)");
        return 1;
      }
    }
  }

  if (!log->finish("exported what was read")) return 2;
  for (const auto& [channel, out] : outs)
    std::printf("%-20s %-12s %8lld messages -> %s.{%s}\n", ips::printable(channel).c_str(),
                out.type.c_str(), static_cast<long long>(out.messages),
                ips::printable(out.stem).c_str(), format == "both" ? "csv,jsonl" : format.c_str());
  const int64_t empty_channel = log->stats().empty_channel_events;
  const std::string empty_note =
      empty_channel > 0 ? ", " + std::to_string(empty_channel) + " on an empty channel (skipped)"
                        : "";
  std::printf("(%lld log events, %lld exported to %s, %lld outside --channels, %lld outside "
              "--from/--to%s)\n",
              static_cast<long long>(events + empty_channel), static_cast<long long>(exported),
              out_dir.c_str(), static_cast<long long>(filtered_channel),
              static_cast<long long>(filtered_time), empty_note.c_str());

  if (log->size() == 0)
    std::fprintf(stderr, "%s: warning: %s is empty: nothing exported\n", kProgram, log_path.c_str());
  if (!unknown.empty()) {
    int64_t n = 0;
    for (const auto& [channel, count] : unknown) n += count;
    std::fprintf(stderr,
                 "%s: warning: skipped %lld messages of no known type (or corrupt), by channel: "
                 "%s\n",
                 kProgram, static_cast<long long>(n), list_counts(unknown).c_str());
  }
  std::map<std::string, int64_t> other;
  for (const auto& [channel, out] : outs)
    if (out.other_type) other[channel] = out.other_type;
  if (!other.empty())
    std::fprintf(stderr,
                 "%s: warning: skipped messages of another type than the channel's first, by "
                 "channel: %s\n",
                 kProgram, list_counts(other).c_str());
  return 0;
}
