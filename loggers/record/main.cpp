// ips-record: records a session from the bus into standard LCM log files (SITE first in every
// file, split by size or time, a JSON sidecar), never blocking the bus. docs/programs.md#ips-record
#include <unistd.h>

#include <cmath>
#include <csignal>
#include <cstdio>
#include <ctime>
#include <ips/site_t.hpp>
#include <spdlog/spdlog.h>

#include "core/channels.hpp"
#include "core/cli.hpp"
#include "core/lcm_url.hpp"
#include "core/node.hpp"
#include "core/site.hpp"
#include "core/text_escape.hpp"
#include "core/version.hpp"
#include "loggers/record/recorder.hpp"

namespace {

constexpr const char* kProgram = "ips-record";

std::string default_out_name() {
  const time_t now = std::time(nullptr);
  std::tm tm{};
  localtime_r(&now, &tm);
  char buf[64];
  std::strftime(buf, sizeof buf, "ips-%Y%m%d-%H%M%S.lcm", &tm);
  return buf;
}

std::string host_name() {
  char buf[256] = {0};
  if (gethostname(buf, sizeof buf - 1) != 0) return "unknown";
  return buf;
}

std::vector<uint8_t> encode_site(const ips::Site& site) {
  const ips::site_t msg = ips::site_to_msg(site, ips::wall_utime_now(), kProgram);
  std::vector<uint8_t> buf(static_cast<size_t>(msg.getEncodedSize()));
  if (msg.encode(buf.data(), 0, static_cast<int>(buf.size())) < 0)
    throw ips::record::RecordError("cannot encode the site as site_t");
  return buf;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"ips-record: records every channel of the bus (or those matching --channels) into "
               "standard LCM log files that lcm-logplayer and every LCM tool read. The first event "
               "of every file is the current SITE, so that each file is self-contained. Files "
               "split by size or time; a JSON sidecar (<out>.json) describes the session. Stop "
               "with Ctrl-C (SIGINT) or SIGTERM: everything received is written before exit.",
               kProgram};
  ips::CommonOptions opts;
  ips::add_common_options(app, opts, {.lcm = true, .site = true, .channels = true});
  std::string out;
  std::string channels_regex = ".*";
  double split_mb = 0, split_minutes = 0, queue_mb = 64, flush_ms = 100, min_free_mb = 200;
  double site_wait_s = 3, duration_s = 0;
  bool force = false;
  app.add_option("--out", out, "log file to write (default: ips-YYYYMMDD-HHMMSS.lcm here); when "
                               "splitting, parts are <stem>.000.lcm, <stem>.001.lcm, ...");
  app.add_option("--channels", channels_regex, "record only channels matching this LCM regex")
      ->capture_default_str();
  app.add_option("--split-mb", split_mb, "start a new file before one would exceed this size")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--split-minutes", split_minutes, "start a new file after this many minutes")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--queue-mb", queue_mb, "received but unwritten messages held in memory; beyond "
                                         "this, messages are dropped and counted")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--flush-ms", flush_ms, "flush the file to the OS every this many ms (bounds "
                                         "what a killed recorder loses)")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 60000.0));
  app.add_option("--min-free-mb", min_free_mb, "refuse to start, and pause, when the disk has "
                                               "less free space than this (a full disk pauses "
                                               "whatever this is; recording resumes by itself)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app.add_option("--site-wait", site_wait_s, "without --site, hold the first messages this many "
                                             "seconds waiting for SITE on the bus")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 3600.0));
  app.add_option("--duration", duration_s, "stop after this many seconds (default: until SIGINT)")
      ->check(CLI::NonNegativeNumber);
  app.add_flag("--force", force, "overwrite existing files");
  int rc = 0;
  if (!ips::parse_command_line(app, opts, argc, argv, rc)) return rc;

  return ips::run_reporting_errors(kProgram, [&]() -> int {
    namespace rec = ips::record;
    rec::RecorderOptions ro;
    ro.session.out = out.empty() ? default_out_name() : out;
    ro.session.split_mb = split_mb;
    ro.session.split_s = split_minutes * 60.0;
    ro.session.force = force;
    ro.session.min_free_bytes = static_cast<uint64_t>(min_free_mb * 1e6);
    ro.session.site_channel = opts.channel(ips::channel::kSite);
    ro.queue_bytes = static_cast<size_t>(queue_mb * 1048576.0);
    ro.flush_interval_s = flush_ms * 1e-3;
    ro.site_wait_s = site_wait_s;
    ro.info.version = ips::version_text();
    ro.info.host = host_name();
    ro.info.lcm_url = ips::effective_lcm_url(opts.lcm_url);
    ro.info.channels_regex = channels_regex;
    ro.info.start_utime = ips::wall_utime_now();
    try {
      rec::preflight(ro.session);
    } catch (const rec::RecordError& e) {
      ips::print_fatal(kProgram, e.what());
      return 2;
    }
    if (!opts.site_path.empty()) {
      ro.site = encode_site(ips::load_site_file(opts.site_path));
      ro.info.site_source = "file " + opts.site_path;
    } else {
      ro.info.site_source = site_wait_s > 0 ? "bus" : "none";
    }

    ips::Node node(kProgram, opts);
    std::unique_ptr<rec::Recorder> recorder;
    try {
      recorder = std::make_unique<rec::Recorder>(ro);
    } catch (const rec::RecordError& e) {
      ips::print_fatal(kProgram, e.what());
      return 2;
    }
    node.subscribe_raw(channels_regex, [&](const lcm::ReceiveBuffer* rbuf, const std::string& ch) {
      // liblcm's own multicast self-test message (sent when a process opens udpm) is not traffic.
      if (ch == "LCM_SELF_TEST") return;
      if (!recorder->offer(ch, rbuf->recv_utime, rbuf->data, rbuf->data_size))
        ++node.counters().drops;
    });
    spdlog::info("{}: recording '{}' from {} into {}{}", kProgram, ips::printable(channels_regex),
                 ro.info.lcm_url, rec::part_path(ro.session, 0).string(),
                 ro.session.split_mb > 0 || ro.session.split_s > 0 ? " (and further parts)" : "");

    const bool tty = isatty(STDERR_FILENO);
    int64_t reported_drops = 0, reported_lost = 0, pauses_seen = 0;
    bool site_warned = false, paused = false;
    std::string sidecar_warned;
    std::string stopped_by;
    const auto t0 = std::chrono::steady_clock::now();
    node.add_timer(1.0, [&] {
      recorder->set_loss_json(node.loss().json());
      const auto s = recorder->stats();
      if (recorder->site_missing() && !site_warned) {
        site_warned = true;
        spdlog::warn("{}: no SITE on {} within {} s and no --site: the log does not start with "
                     "the site (a SITE arriving later is recorded and heads later files)",
                     kProgram, ro.session.site_channel, site_wait_s);
      }
      if (s.dropped > reported_drops) {
        spdlog::warn("{}: cannot write fast enough ({:.1f} MB unwritten): {} messages dropped so "
                     "far",
                     kProgram, static_cast<double>(s.unwritten_bytes) / 1048576.0, s.dropped);
        reported_drops = s.dropped;
        node.report_error("messages dropped: the writer falls behind");
      }
      // The disk: paused (HEALTH in error, saying why and what it costs so far), and resumed.
      node.counters().drops += s.lost_disk - reported_lost;
      reported_lost = s.lost_disk;
      if (s.paused) {
        const std::string text = "paused: " + s.pause.reason + " since " +
                                 rec::iso_utc(s.pause.start_utime) + ": " +
                                 std::to_string(s.pause.lost) + " messages not written so far";
        if (!paused || s.pauses != pauses_seen)
          spdlog::error("{}: {}; resumes by itself when space returns", kProgram, text);
        paused = true;
        pauses_seen = s.pauses;
        node.set_state(ips::health_t::STATE_ERROR);
        node.report_lasting_error("disk", text);
      } else if (paused || s.pauses != pauses_seen) {  // also a pause shorter than a second
        paused = false;
        pauses_seen = s.pauses;
        const std::string text =
            "resumed after " + s.pause.reason + ": " + std::to_string(s.pause.lost) +
            " messages lost from " + rec::iso_utc(s.pause.start_utime) + " to " +
            rec::iso_utc(s.pause.end_utime);
        spdlog::warn("{}: {}", kProgram, text);
        node.end_lasting_error("disk");
        node.set_state(ips::health_t::STATE_OK);
        node.set_last_error(text);  // recording again: OK, the losses counted and said
      }
      if (!s.sidecar_error.empty() && s.sidecar_error != sidecar_warned)
        spdlog::warn("{}: {}", kProgram, s.sidecar_error);
      sidecar_warned = s.sidecar_error;
      if (const auto err = recorder->error()) {
        spdlog::error("{}: {}", kProgram, *err);
        stopped_by = "error";
        node.stop();
      }
      if (tty) {
        const double secs =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        std::fprintf(stderr, "\r%s: %6.0f s  %lld events  %.1f MB  file %zu  %lld dropped   ",
                     kProgram, secs, static_cast<long long>(s.written),
                     static_cast<double>(s.bytes) / 1e6, s.parts,
                     static_cast<long long>(s.dropped));
      }
    });
    if (duration_s > 0)
      node.add_timer(duration_s, [&] {
        stopped_by = "duration";
        node.stop();
      });
    const int loop_rc = node.run();
    if (tty) std::fprintf(stderr, "\n");
    if (stopped_by.empty())
      stopped_by = node.stop_signal() == SIGTERM  ? "SIGTERM"
                   : node.stop_signal() == SIGINT ? "SIGINT"
                   : node.stop_signal() == SIGHUP ? "SIGHUP"
                                                  : "LCM failure";
    try {
      recorder->set_loss_json(node.loss().json());
      recorder->stop(stopped_by);
    } catch (const std::exception& e) {
      spdlog::error("{}: {}", kProgram, e.what());
      return 1;
    }
    const auto s = recorder->stats();
    spdlog::info("{}: {} events in {} file(s), {:.1f} MB, {} dropped; sidecar {}", kProgram,
                 s.written, s.parts, static_cast<double>(s.bytes) / 1e6, s.dropped,
                 rec::sidecar_path(ro.session.out).string());
    if (s.pauses > 0)
      spdlog::warn("{}: the disk paused the recording {} time(s){}: {} messages not written",
                   kProgram, s.pauses, s.paused ? " (still paused at the end)" : "", s.lost_disk);
    if (const auto err = recorder->error()) {
      ips::print_fatal(kProgram, *err);
      return 1;
    }
    return loop_rc;
  });
}
