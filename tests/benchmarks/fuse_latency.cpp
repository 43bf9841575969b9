// ips-fuse-latency: issue 10's performance figure, a timed run against a live ips-fuse. It
// publishes, over real LCM, UWB ranges from --tags tags to --anchors anchors at --range-hz
// (tags walking circles in a 20 x 20 m hall, ranges exact plus 5 cm noise) and each tag's IMU at
// --imu-hz, and subscribes POSE_FUSED. The site it prints for ips-fuse (--print-site) sets
// publish_period_s to 0, so every range gives a pose stamped with that range's time: the latency
// is the wall time from the range's publication to its pose's arrival. Reports the percentiles,
// the poses missing, and with --cpu-pid the CPU used by that process meanwhile. As a baseline it
// also receives its own ranges: the bus's and the machine's share of the latency, without
// ips-fuse. Per range, the pose's arrival minus the range's own arrival is what ips-fuse adds
// (its receive, update and publish, and the second hop). Every range is numbered per tag and
// anchor (uwb_range_t.seq), so a receiver's HEALTH seq_lost counts what the bus lost of them;
// --json writes the figures and the messages published per channel for scripts/bench-bus-load.
#include <poll.h>
#include <sys/resource.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <Eigen/Core>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <ips/imu_t.hpp>
#include <ips/pose_t.hpp>
#include <ips/uwb_range_t.hpp>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "core/lcm_udpm_receiver.hpp"
#include "core/lcm_url.hpp"
#include "core/tag_selector.hpp"
#include "core/time.hpp"
#include "core/version.hpp"

namespace {

constexpr double kPi = 3.14159265358979323846;
using Clock = std::chrono::steady_clock;

struct Options {
  int tags = 10;
  int anchors = 8;
  double range_hz = 10;
  double imu_hz = 100;
  double seconds = 20;
  double warmup_s = 2;
  double drain_s = 0.5;
  std::string lcm_url;
  int cpu_pid = 0;
  int shards = 1;
  std::string json_path;
  bool print_site = false;
};

Eigen::Vector3d anchor_position(int k, int n) {
  // On a 20 x 20 m hall's walls at 2.5 m, evenly around.
  const double a = 2 * kPi * k / n;
  return {10 + 10 * std::cos(a), 10 + 10 * std::sin(a), 2.5};
}

std::string tag_id(int i) {
  return (i < 10 ? "T0" : "T") + std::to_string(i);
}

std::string site_yaml(const Options& o) {
  std::ostringstream s;
  s << "# ips-fuse-latency's hall: " << o.anchors << " anchors, " << o.tags << " tags.\n"
    << "name: latency-hall\nanchors:\n";
  for (int k = 0; k < o.anchors; ++k) {
    const Eigen::Vector3d p = anchor_position(k, o.anchors);
    s << "  - {id: A" << k + 1 << ", kind: uwb, position: [" << p.x() << ", " << p.y() << ", "
      << p.z() << "]}\n";
  }
  s << "tags:\n";
  for (int i = 0; i < o.tags; ++i) s << "  - {id: " << tag_id(i) << ", height_m: 1.2}\n";
  s << "estimators:\n  fuse:\n    publish_period_s: 0\n    range_sigma_m: 0.05\n";
  return s.str();
}

// Tag i walks a circle of radius 2 + 0.5 i m around the hall's centre at 1 m/s.
Eigen::Vector3d tag_position(int i, double t) {
  const double r = 2 + 0.5 * (i % 14);
  const double a = t / r + i;
  return {10 + r * std::cos(a), 10 + r * std::sin(a), 1.2};
}

double cpu_seconds(int pid) {
  std::ifstream f("/proc/" + std::to_string(pid) + "/stat");
  std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  const size_t close = text.rfind(')');
  if (close == std::string::npos) return std::nan("");
  std::istringstream rest(text.substr(close + 2));
  std::string field;
  double utime = 0, stime = 0;
  // Fields after the name: state is field 3; utime and stime are fields 14 and 15.
  for (int k = 3; k <= 15 && rest >> field; ++k) {
    if (k == 14) utime = std::stod(field);
    if (k == 15) stime = std::stod(field);
  }
  return (utime + stime) / static_cast<double>(sysconf(_SC_CLK_TCK));
}

// The process's resident memory now and at its peak (VmRSS, VmHWM of /proc/PID/status), MB.
std::pair<double, double> rss_mb(int pid) {
  std::ifstream f("/proc/" + std::to_string(pid) + "/status");
  double now = std::nan(""), peak = std::nan("");
  for (std::string line; std::getline(f, line);) {
    std::istringstream in(line);
    std::string key;
    double kb = 0;
    in >> key >> kb;
    if (key == "VmRSS:") now = kb / 1024.0;
    if (key == "VmHWM:") peak = kb / 1024.0;
  }
  return {now, peak};
}

double max_of(const std::vector<double>& v) {
  return v.empty() ? std::nan("") : *std::max_element(v.begin(), v.end());
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const double k = (static_cast<double>(v.size()) - 1) * p / 100.0;
  const size_t lo = static_cast<size_t>(k);
  const size_t hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (v[hi] - v[lo]) * (k - static_cast<double>(lo));
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  CLI::App app{
      "ips-fuse-latency: publishes UWB ranges and IMU samples for many tags to a running "
      "ips-fuse over LCM and measures the latency from each range's publication to the "
      "POSE_FUSED it causes. Start ips-fuse with the site from --print-site.",
      "ips-fuse-latency"};
  app.add_option("--tags", o.tags, "tags")->check(CLI::Range(1, 1000));
  app.add_option("--anchors", o.anchors, "anchors ranged by every tag")->check(CLI::Range(3, 32));
  app.add_option("--range-hz", o.range_hz, "ranging rate per tag and anchor")
      ->check(CLI::Range(0.1, 1000.0));
  app.add_option("--imu-hz", o.imu_hz, "IMU rate per tag (0: none)")->check(CLI::Range(0.0, 2000.0));
  app.add_option("--seconds", o.seconds, "measured time")->check(CLI::Range(0.5, 3600.0));
  app.add_option("--warmup", o.warmup_s, "seconds published before measuring")
      ->check(CLI::Range(0.0, 60.0));
  app.add_option("--drain", o.drain_s,
                 "after the measured time, wait at most this long for the poses still missing "
                 "(ends as soon as none is)")
      ->check(CLI::Range(0.0, 600.0))
      ->capture_default_str();
  app.add_option("--lcm-url", o.lcm_url, "LCM URL (default: LCM_DEFAULT_URL or LCM's)");
  app.add_option("--cpu-pid", o.cpu_pid,
                 "report the CPU time and resident memory of this process (ips-fuse)");
  app.add_option("--shards", o.shards,
                 "also report the added latency per shard of N (tags by ips-fuse --shard's hash)")
      ->check(CLI::Range(1, ips::kMaxShards));
  app.add_option("--json", o.json_path,
                 "write the figures, and the messages published per channel, to this file");
  app.add_flag("--print-site", o.print_site, "print the site for ips-fuse --site and exit");
  app.set_version_flag("--version", ips::version_line("ips-fuse-latency"),
                       "print the program's version and build, and exit");
  CLI11_PARSE(app, argc, argv);
  if (o.print_site) {
    std::fputs(site_yaml(o).c_str(), stdout);
    return 0;
  }

  lcm::LCM bus(o.lcm_url);
  if (!bus.good()) {
    std::fprintf(stderr, "ips-fuse-latency: cannot open LCM (%s)\n", o.lcm_url.c_str());
    return 2;
  }
  // This process reads the bus itself (core/lcm_udpm_receiver.hpp), for the kernel's receive
  // stamp of every datagram (SO_TIMESTAMP): liblcm's recv_utime is its receive thread's clock
  // after that thread woke, which puts this process's own wake-up into every figure.
  const std::string url = ips::effective_lcm_url(o.lcm_url);
  if (ips::lcm_url_udpm_port(url) == 0) {
    std::fprintf(stderr, "ips-fuse-latency: '%s' is not a udpm:// URL: the latency is measured "
                 "on LCM's UDP multicast\n", url.c_str());
    return 2;
  }
  std::unique_ptr<ips::LcmUdpmReceiver> rx;
  try {
    rx = std::make_unique<ips::LcmUdpmReceiver>(url);
  } catch (const ips::LcmOpenError& e) {
    std::fprintf(stderr, "ips-fuse-latency: %s\n", e.what());
    return 2;
  }
  // Each range measured, by (tag, utime), until both its own copy and its pose have come back.
  struct Pending {
    Clock::time_point sent;     // published, by this loop's clock
    int64_t sent_wall_us = 0;   // the same by the wall clock (the kernel's stamps are wall time)
    bool heard = false;         // its own copy came back:
    Clock::time_point heard_at; //   handled by this loop
    int64_t stamp_us = 0;       //   its kernel receive stamp
    bool posed = false;         // its pose came back
  };
  std::map<std::pair<std::string, int64_t>, Pending> pending;
  // Per range: publication to pose handled (latency_us); to its own copy handled (own_us, the
  // bus's loop through the kernel and this process); pose handled minus own copy handled
  // (added_us: what ips-fuse adds, as this loop sees it). By the kernel's stamps: publication to
  // the own copy's stamp (delivery_us, the kernel's share), that stamp to its handling here
  // (wake_us: a subscriber's wake-up and read, the machine's share of any hop), and the pose's
  // stamp minus the own copy's (added_stamp_us: ips-fuse's whole share, its own wake-up
  // included, none of this process's).
  std::vector<double> latency_us, own_us, added_us, delivery_us, wake_us, added_stamp_us;
  // The added latency by the kernel's stamps, by the tag's shard (index 0 for shard 1).
  std::vector<std::vector<double>> added_by_shard(static_cast<size_t>(o.shards));
  int64_t measured_sent = 0, poses = 0, poses_warmup = 0, foreign = 0, undecodable = 0;
  bool measuring = false;
  const auto us = [](auto d) { return std::chrono::duration<double, std::micro>(d).count(); };
  const auto on_pose = [&](const ips::pose_t& p, int64_t stamp_us) {
    const auto now = Clock::now();
    ++poses;
    const auto it = pending.find({p.tag_id, p.utime});
    if (it == pending.end() || it->second.posed) return;
    Pending& m = it->second;
    m.posed = true;
    latency_us.push_back(us(now - m.sent));
    if (m.heard) {
      added_us.push_back(us(now - m.heard_at));
      const auto added = static_cast<double>(stamp_us - m.stamp_us);
      added_stamp_us.push_back(added);
      added_by_shard[static_cast<size_t>(ips::shard_of(p.tag_id, o.shards) - 1)].push_back(added);
      pending.erase(it);
    }
  };
  const auto on_range = [&](const ips::uwb_range_t& r, int64_t stamp_us) {
    const auto now = Clock::now();
    const int64_t wall_now = ips::wall_utime_now();
    const auto it = pending.find({r.tag_id, r.utime});
    if (it == pending.end() || it->second.heard) return;
    Pending& m = it->second;
    m.heard = true;
    m.heard_at = now;
    m.stamp_us = stamp_us;
    own_us.push_back(us(now - m.sent));
    delivery_us.push_back(static_cast<double>(stamp_us - m.sent_wall_us));
    wake_us.push_back(static_cast<double>(wall_now - stamp_us));
    if (m.posed) pending.erase(it);  // (a pose before its range: not seen, but not kept forever)
  };
  const auto on_message = [&](const ips::LcmReassembler::Message& msg, int64_t stamp_us) {
    const int size = static_cast<int>(msg.size);
    if (msg.channel == "POSE_FUSED") {
      ips::pose_t p;
      if (p.decode(msg.data, 0, size) < 0) { ++undecodable; return; }
      on_pose(p, stamp_us);
    } else if (msg.channel == "UWB_RANGE") {
      ips::uwb_range_t r;
      if (r.decode(msg.data, 0, size) < 0) { ++undecodable; return; }
      on_range(r, stamp_us);
    }
  };

  // Waits up to timeout_s for a datagram, then handles everything that is there (a backlog would
  // add to the latencies measured). The wait is to the microsecond (ppoll): rounded down to
  // poll's milliseconds it was 0 below 1 ms, and at 1000 messages a second and more the tool
  // spun a whole core, which it then took from ips-fuse.
  auto receive_all = [&](double timeout_s) {
    pollfd pfd{rx->fd(), POLLIN, 0};
    const auto ns = static_cast<long>(std::max(0.0, timeout_s) * 1e9);
    const timespec wait{ns / 1000000000L, ns % 1000000000L};
    int ready = ppoll(&pfd, 1, &wait, nullptr);
    while (ready > 0) {
      if (rx->read_batch(on_message, [&](const std::string&) { ++foreign; }) < 0) {
        std::fprintf(stderr, "ips-fuse-latency: reading the bus: %s\n", std::strerror(errno));
        std::exit(1);
      }
      ready = poll(&pfd, 1, 0);
    }
  };

  std::mt19937_64 rng(1);
  std::normal_distribution<double> noise(0.0, 0.05);
  const auto start = Clock::now();
  const int64_t wall0_us = std::chrono::duration_cast<std::chrono::microseconds>(
                               std::chrono::system_clock::now().time_since_epoch())
                               .count();
  const double range_period = 1.0 / o.range_hz;
  const double imu_period = o.imu_hz > 0 ? 1.0 / o.imu_hz : 0;
  // Each message's due time: ranges of tag i from anchor k staggered over the period.
  struct Stream {
    double next_s;
    int tag, anchor;  // anchor -1: the IMU
    int32_t seq = 0;  // the stream's next number (uwb_range_t.seq per tag and anchor)
  };
  std::vector<Stream> streams;
  for (int i = 0; i < o.tags; ++i) {
    for (int k = 0; k < o.anchors; ++k)
      streams.push_back(
          {range_period * (k + static_cast<double>(i) / o.tags) / o.anchors, i, k, 0});
    if (imu_period > 0) streams.push_back({imu_period * i / o.tags, i, -1, 0});
  }
  // The streams by due time, soonest first (a heap: not a scan of every stream per message).
  const auto later = [&](size_t a, size_t b) { return streams[a].next_s > streams[b].next_s; };
  std::vector<size_t> due(streams.size());
  for (size_t k = 0; k < due.size(); ++k) due[k] = k;
  std::make_heap(due.begin(), due.end(), later);
  double cpu0 = 0, measure_start_s = 0;
  const double end_s = o.warmup_s + o.seconds;
  ips::uwb_range_t r{};
  r.source = "ips-fuse-latency";
  ips::imu_t imu{};
  imu.source = "ips-fuse-latency";
  imu.device_utime = -1;
  for (int a = 0; a < 3; ++a) imu.mag_ut[a] = std::nan("");
  int64_t published_ranges = 0, published_imu = 0;
  for (;;) {
    const double now_s = std::chrono::duration<double>(Clock::now() - start).count();
    if (!measuring && now_s >= o.warmup_s) {
      measuring = true;
      measure_start_s = now_s;
      latency_us.clear();
      own_us.clear();
      added_us.clear();
      delivery_us.clear();
      wake_us.clear();
      added_stamp_us.clear();
      for (auto& v : added_by_shard) v.clear();
      pending.clear();
      poses_warmup = poses;
      poses = 0;
      if (o.cpu_pid) cpu0 = cpu_seconds(o.cpu_pid);
    }
    // Everything due before the end is published, even when this thread was held up past it
    // (a loaded machine): the count published does not depend on the scheduler.
    while (streams[due.front()].next_s <= now_s && streams[due.front()].next_s < end_s) {
      std::pop_heap(due.begin(), due.end(), later);
      Stream& s = streams[due.back()];
      {
        const int64_t utime = wall0_us + static_cast<int64_t>(std::llround(s.next_s * 1e6));
        const std::string id = tag_id(s.tag);
        if (s.anchor >= 0) {
          r.utime = utime;
          r.tag_id = id;
          r.anchor_id = "A" + std::to_string(s.anchor + 1);
          r.range_m = (tag_position(s.tag, s.next_s) - anchor_position(s.anchor, o.anchors)).norm() +
                      noise(rng);
          r.seq = s.seq++;
          if (measuring && s.next_s >= o.warmup_s) {  // not one due in the warmup, published late
            Pending& m = pending[{id, utime}];
            m.sent = Clock::now();
            m.sent_wall_us = ips::wall_utime_now();
            ++measured_sent;
          }
          bus.publish("UWB_RANGE", &r);
          ++published_ranges;
          s.next_s += range_period;
        } else {
          imu.utime = utime;
          imu.device_id = id;
          imu.accel[0] = imu.accel[1] = 0;
          imu.accel[2] = 9.81;
          imu.gyro[0] = imu.gyro[1] = 0;
          imu.gyro[2] = 1.0 / (2 + 0.5 * (s.tag % 14));  // walking the circle
          bus.publish("IMU", &imu);
          ++published_imu;
          s.next_s += imu_period;
        }
      }
      std::push_heap(due.begin(), due.end(), later);
    }
    if (now_s >= end_s) break;
    // Receive until the next message is due.
    const double next_due = std::min(end_s, streams[due.front()].next_s);
    receive_all(next_due - std::chrono::duration<double>(Clock::now() - start).count());
  }
  // The last poses (and the own ranges): at most --drain seconds, less once none is missing.
  const auto drain_end = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                            std::chrono::duration<double>(o.drain_s));
  while (Clock::now() < drain_end && !pending.empty()) receive_all(0.05);
  const double measured_s =
      std::chrono::duration<double>(Clock::now() - start).count() - measure_start_s;
  const double cpu1 = o.cpu_pid ? cpu_seconds(o.cpu_pid) : 0;
  std::printf(
      "ips-fuse-latency: %d tags x %d anchors at %g Hz (%g ranges/s) + IMU %g Hz per tag (%g/s), "
      "%g s measured\n",
      o.tags, o.anchors, o.range_hz, o.tags * o.anchors * o.range_hz, o.imu_hz, o.tags * o.imu_hz,
      o.seconds);
  const auto missing = static_cast<size_t>(std::count_if(
      pending.begin(), pending.end(), [](const auto& kv) { return !kv.second.posed; }));
  std::printf("ranges published %lld, poses matched %zu, missing %zu\n",
              static_cast<long long>(measured_sent), latency_us.size(), missing);
  std::printf("latency us: p50 %.0f p90 %.0f p99 %.0f p99.9 %.0f max %.0f\n",
              percentile(latency_us, 50), percentile(latency_us, 90), percentile(latency_us, 99),
              percentile(latency_us, 99.9),
              max_of(latency_us));
  std::printf("baseline, own ranges heard back, us: p50 %.0f p90 %.0f p99 %.0f max %.0f\n",
              percentile(own_us, 50), percentile(own_us, 90), percentile(own_us, 99),
              max_of(own_us));
  std::printf("added by ips-fuse (pose minus own range arrival), us: p50 %.0f p90 %.0f p99 %.0f "
              "max %.0f\n",
              percentile(added_us, 50), percentile(added_us, 90), percentile(added_us, 99),
              max_of(added_us));
  std::printf("by the kernel's receive stamps (SO_TIMESTAMP), us: a range's delivery p50 %.0f p99 "
              "%.0f; this process's wake-up and read of it p50 %.0f p90 %.0f p99 %.0f; added by "
              "ips-fuse (its pose's stamp minus its range's: ips-fuse's wake-up, work and publish) "
              "p50 %.0f p90 %.0f p99 %.0f max %.0f\n",
              percentile(delivery_us, 50), percentile(delivery_us, 99), percentile(wake_us, 50),
              percentile(wake_us, 90), percentile(wake_us, 99), percentile(added_stamp_us, 50),
              percentile(added_stamp_us, 90), percentile(added_stamp_us, 99),
              max_of(added_stamp_us));
  if (foreign + undecodable > 0)
    std::printf("datagrams not LCM's: %lld; messages that did not decode: %lld\n",
                static_cast<long long>(foreign), static_cast<long long>(undecodable));
  nlohmann::json out;
  if (o.shards > 1) {
    out["added_us_by_shard"] = nlohmann::json::array();
    for (int k = 1; k <= o.shards; ++k) {
      const std::vector<double>& v = added_by_shard[static_cast<size_t>(k - 1)];
      std::printf("  shard %d/%d: %zu poses, added (stamps) p50 %.0f p99 %.0f us\n", k, o.shards,
                  v.size(),
                  percentile(v, 50), percentile(v, 99));
      out["added_us_by_shard"].push_back(
          {{"shard", k}, {"n", v.size()}, {"p50", percentile(v, 50)}, {"p99", percentile(v, 99)}});
    }
  }
  if (o.cpu_pid) {
    const auto [rss, peak] = rss_mb(o.cpu_pid);
    const double cpu_pct = 100.0 * (cpu1 - cpu0) / measured_s;
    std::printf("cpu of pid %d: %.1f %% of one core; resident memory %.1f MB (peak %.1f MB)\n",
                o.cpu_pid, cpu_pct, rss, peak);
    out["cpu_pid"] = {{"pid", o.cpu_pid}, {"cpu_pct", cpu_pct}, {"rss_mb", rss}, {"peak_mb", peak}};
  }
  // This process's own share, over its whole run.
  rusage self{};
  getrusage(RUSAGE_SELF, &self);
  const auto tv_s = [](const timeval& t) {
    return static_cast<double>(t.tv_sec) + static_cast<double>(t.tv_usec) / 1e6;
  };
  const double run_s = std::chrono::duration<double>(Clock::now() - start).count();
  const double self_cpu_pct = 100.0 * (tv_s(self.ru_utime) + tv_s(self.ru_stime)) / run_s;
  const double self_peak_mb = static_cast<double>(self.ru_maxrss) / 1024.0;
  std::printf("published, whole run (warm-up included): UWB_RANGE %lld, IMU %lld; poses received "
              "%lld; this process: cpu %.1f %% of one core, peak resident memory %.1f MB\n",
              static_cast<long long>(published_ranges), static_cast<long long>(published_imu),
              static_cast<long long>(poses_warmup + poses), self_cpu_pct, self_peak_mb);
  if (!o.json_path.empty()) {
    const auto pct = [&](const std::vector<double>& v) {
      return nlohmann::json{{"n", v.size()},
                            {"p50", percentile(v, 50)},
                            {"p90", percentile(v, 90)},
                            {"p99", percentile(v, 99)},
                            {"max", max_of(v)}};
    };
    out["tags"] = o.tags;
    out["anchors"] = o.anchors;
    out["seconds"] = o.seconds;
    out["measured_ranges"] = measured_sent;
    out["poses_missing"] = missing;
    out["latency_us"] = pct(latency_us);
    out["baseline_us"] = pct(own_us);
    out["added_us"] = pct(added_us);
    out["delivery_us"] = pct(delivery_us);
    out["wake_us"] = pct(wake_us);
    out["added_stamp_us"] = pct(added_stamp_us);
    out["published"] = {{"UWB_RANGE", published_ranges}, {"IMU", published_imu}};
    out["poses_received"] = poses_warmup + poses;
    out["self"] = {{"pid", static_cast<int>(getpid())},
                   {"cpu_pct", self_cpu_pct},
                   {"peak_mb", self_peak_mb},
                   {"run_s", run_s}};
    std::ofstream f(o.json_path);
    // nlohmann writes NaN as null.
    f << out.dump(1) << "\n";
    if (!f) {
      std::fprintf(stderr, "ips-fuse-latency: cannot write %s\n", o.json_path.c_str());
      return 2;
    }
  }
  return latency_us.empty() ? 1 : 0;
}
