// Writes the LCM log the console tests of ips-view play (tests/viewer/view_console.sh): a
// two-floor site with a floor plan per floor (SVG, carried in the site) and zones, and what the
// page has to show from it, at known times:
//   - T1 walks a loop on floor 0 (through the zone "lab": ZONE_EVENT enter at 5 s, an alert; leave
//     at 12 s), climbs to floor 1 between 20 and 24 s (ALTITUDE floor 0 -> 1) and walks there;
//     TRUTH, POSE_FUSED and POSE_UWB at 10 Hz;
//   - T2 and T10 stand on floor 0 (the natural sort puts T2 before T10); T2 goes silent at 14 s:
//     an ALERT raised at 15 s (tag silent) and cleared at 25 s when it comes back;
//   - HEALTH of one process ("ips-zones") every second.
// With --tags N --channels C (the benchmark): N walking tags on C pose channels at 10 Hz, no
// events. Deterministic: the same arguments give the same bytes.
//
//   view_console_log OUT.lcm [--duration S] [--tags N --channels C]
#include <lcm/lcm-cpp.hpp>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ips/alert_t.hpp>
#include <ips/altitude_t.hpp>
#include <ips/health_t.hpp>
#include <ips/pose_t.hpp>
#include <ips/site_t.hpp>
#include <ips/zone_event_t.hpp>
#include <limits>
#include <string>
#include <vector>

#include "core/site.hpp"
#include "core/site_layout.hpp"

namespace {

constexpr int64_t kStart = 1767225600000000;  // 2026-01-01 00:00:00 UTC
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

struct Writer {
  lcm::LogFile log;
  int64_t n = 0;
  explicit Writer(const std::string& path) : log(path, "w") {}
  template <class M>
  void write(const char* channel, double t_s, const M& msg) {
    std::vector<uint8_t> buf(static_cast<size_t>(msg.getEncodedSize()));
    msg.encode(buf.data(), 0, static_cast<int>(buf.size()));
    lcm::LogEvent e;
    e.eventnum = n++;
    e.timestamp = kStart + static_cast<int64_t>(std::llround(t_s * 1e6));
    e.channel = channel;
    e.datalen = static_cast<int32_t>(buf.size());
    e.data = buf.data();
    log.writeEvent(&e);
  }
};

std::string plan_svg(const char* label, const char* colour) {
  return std::string("<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"240\" height=\"160\" "
                     "viewBox=\"0 0 240 160\"><rect width=\"240\" height=\"160\" fill=\"#f5f5f5\" "
                     "stroke=\"#333\" stroke-width=\"4\"/><path d=\"M120 0V70M0 100H90\" "
                     "stroke=\"#333\" stroke-width=\"4\"/><rect x=\"160\" y=\"20\" width=\"60\" "
                     "height=\"40\" fill=\"") +
         colour + "\"/><text x=\"10\" y=\"30\" font-size=\"20\">" + label + "</text></svg>";
}

ips::pose_t pose(const char* source, const std::string& tag, double t_s, double x, double y,
                 double z, double sigma, bool flat) {
  ips::pose_t p{};
  p.utime = kStart + static_cast<int64_t>(std::llround(t_s * 1e6));
  p.source = source;
  p.tag_id = tag;
  p.position[0] = x;
  p.position[1] = y;
  p.position[2] = z;
  for (double& c : p.position_cov) c = 0;
  p.position_cov[0] = p.position_cov[4] = sigma * sigma;
  p.position_cov[8] = flat ? kNaN : sigma * sigma;
  p.velocity[0] = p.velocity[1] = p.velocity[2] = kNaN;
  p.heading_rad = kNaN;
  p.num_used = 4;
  p.residual_m = kNaN;
  p.status = ips::pose_t::STATUS_OK | (flat ? ips::pose_t::STATUS_2D : 0);
  return p;
}

// T1's path: a loop on floor 0 (0-20 s), the stairs (20-24 s), a loop on floor 1.
void t1_at(double t, double& x, double& y, double& z) {
  const double loop = 2 * M_PI * std::fmod(t, 20.0) / 20.0;
  x = 6 + 3 * std::cos(loop - M_PI);
  y = 4 + 2.5 * std::sin(loop - M_PI);
  z = 1.2;
  if (t >= 20 && t < 24) {
    x = 11 + (t - 20) * 0.5;
    y = 4;
    z = 1.2 + 3.5 * (t - 20) / 4;
  } else if (t >= 24) {
    z = 4.7;
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || std::strcmp(argv[1], "--help") == 0) {
    std::fprintf(stderr, "usage: view_console_log OUT.lcm [--duration S] [--tags N --channels C]\n");
    return 2;
  }
  const std::string out = argv[1];
  double duration = 40;
  int bench_tags = 0, bench_channels = 0;
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string k = argv[i];
    if (k == "--duration") duration = std::atof(argv[i + 1]);
    else if (k == "--tags") bench_tags = std::atoi(argv[i + 1]);
    else if (k == "--channels") bench_channels = std::atoi(argv[i + 1]);
    else {
      std::fprintf(stderr, "view_console_log: unknown option %s\n", k.c_str());
      return 2;
    }
  }
  Writer w(out);
  if (!w.log.good()) {
    std::fprintf(stderr, "view_console_log: cannot write %s\n", out.c_str());
    return 1;
  }

  const std::string site_yaml =
      std::string("name: console-test\n"
                  "anchors:\n"
                  "  - {id: A1, position: [0, 0, 2.4]}\n"
                  "  - {id: A2, position: [12, 0, 2.4]}\n"
                  "  - {id: A3, position: [12, 8, 2.4]}\n"
                  "  - {id: A4, position: [0, 8, 2.4]}\n"
                  "floors:\n"
                  "  - {index: 0, name: Ground, height_m: 0, plan: {image: ground.svg, origin: [-1, "
                  "-1], size_m: [15, 10]}}\n"
                  "  - {index: 1, name: First, height_m: 3.5, plan: {image: first.svg, origin: "
                  "[-1, -1], size_m: [15, 10]}}\n"
                  "zones:\n"
                  "  - {id: lab, name: Lab bench, floor: 0, polygon: [[4.5, 0.5], [7.5, 0.5], "
                  "[7.5, 2.5], [4.5, 2.5]], alert: enter}\n"
                  "  - {id: office, name: Office, floor: 1, polygon: [[7, 5], [10, 5], [10, 7.5], "
                  "[7, 7.5]]}\n"
                  "plan_images:\n"
                  "  ground.svg: \"data:image/svg+xml;base64,") +
      ips::base64_encode(plan_svg("Ground floor", "#c8e6c9")) +
      "\"\n  first.svg: \"data:image/svg+xml;base64," +
      ips::base64_encode(plan_svg("First floor", "#bbdefb")) + "\"\n";
  const ips::Site site = ips::parse_site_text(site_yaml, "view_console_log");

  const bool bench = bench_tags > 0;
  const char* kChannels[] = {"TRUTH",    "POSE_FUSED", "POSE_UWB", "POSE_TDOA",
                             "POSE_AOA", "POSE_PDR",   "POSE_INS"};
  int64_t zone_seq = 0, alert_seq = 0;
  for (int k = 0; k <= static_cast<int>(duration * 10); ++k) {
    const double t = k * 0.1;
    if (k % 50 == 0) w.write("SITE", t, ips::site_to_msg(site, kStart + k * 100000, "view_console_log"));
    if (bench) {
      for (int i = 0; i < bench_tags; ++i) {
        const double a = 2 * M_PI * (t / 30.0 + i / static_cast<double>(bench_tags));
        const std::string tag = "T" + std::to_string(i + 1);
        for (int c = 0; c < bench_channels && c < 7; ++c)
          w.write(kChannels[c], t,
                  pose(kChannels[c], tag, t, 6 + 4 * std::cos(a) + 0.05 * c,
                       4 + 3 * std::sin(a) + 0.05 * c, 1.2, 0.1, c > 0));
      }
      continue;
    }
    double x = 0, y = 0, z = 0;
    t1_at(t, x, y, z);
    w.write("TRUTH", t, pose("sim", "T1", t, x, y, z, 0, false));
    w.write("POSE_FUSED", t, pose("fuse", "T1", t, x + 0.08, y - 0.05, z, 0.12, false));
    w.write("POSE_UWB", t, pose("uwb_twr", "T1", t, x - 0.1, y + 0.07, z, 0.2, true));
    if (t < 14 || t >= 25) w.write("POSE_FUSED", t, pose("fuse", "T2", t, 9.0, 2.0, 1.2, 0.1, false));
    w.write("POSE_FUSED", t, pose("fuse", "T10", t, 10.0, 6.5, 1.2, 0.1, false));
    if (k % 5 == 0) {
      ips::altitude_t a{};
      a.utime = kStart + k * 100000;
      a.source = "altitude";
      a.tag_id = "T1";
      a.height_m = z;
      a.height_std_m = 0.1;
      a.vertical_speed_mps = kNaN;
      a.floor = z > 3.0 ? 1 : 0;
      a.floor_valid = true;
      a.relative = false;
      w.write("ALTITUDE", t, a);
    }
    if (k % 10 == 0) {
      ips::health_t h{};
      h.utime = kStart + k * 100000;
      h.source = "ips-zones";
      h.host = "lab-pc";
      h.pid = 4242;
      h.state = ips::health_t::STATE_OK;
      h.uptime_us = k * 100000;
      h.recv_buf_bytes = -1;
      w.write("HEALTH", t, h);
    }
    const auto zone_event = [&](int8_t event, double dwell, bool alert) {
      ips::zone_event_t e{};
      e.utime = kStart + k * 100000;
      e.source = "ips-zones";
      e.seq = zone_seq++;
      e.tag_id = "T1";
      e.zone_id = "lab";
      e.zone_name = "Lab bench";
      e.floor = 0;
      e.event = event;
      e.dwell_s = dwell;
      e.position[0] = x;
      e.position[1] = y;
      e.position[2] = z;
      e.pose_channel = "POSE_FUSED";
      e.alert = alert;
      w.write("ZONE_EVENT", t, e);
    };
    const auto alert = [&](int64_t id, int8_t kind, int8_t state, const char* subject,
                           const char* text) {
      ips::alert_t a{};
      a.utime = kStart + k * 100000;
      a.source = "ips-zones";
      a.seq = alert_seq++;
      a.id = id;
      a.kind = kind;
      a.severity = ips::alert_t::SEVERITY_WARNING;
      a.state = state;
      a.subject = subject;
      a.text = text;
      w.write("ALERT", t, a);
    };
    if (k == 50) {
      zone_event(ips::zone_event_t::EVENT_ENTER, 0, true);
      alert(1, ips::alert_t::KIND_ZONE, ips::alert_t::STATE_RAISED, "T1/lab",
            "T1 entered Lab bench");
    }
    if (k == 120) zone_event(ips::zone_event_t::EVENT_LEAVE, 7.0, false);
    if (k == 150)
      alert(2, ips::alert_t::KIND_TAG_SILENT, ips::alert_t::STATE_RAISED, "T2",
            "T2: no pose on POSE_FUSED for 1.0 s");
    if (k == 250)
      alert(2, ips::alert_t::KIND_TAG_SILENT, ips::alert_t::STATE_CLEARED, "T2",
            "T2: poses again on POSE_FUSED");
  }
  std::fflush(w.log.getFilePtr());
  std::fprintf(stderr, "view_console_log: wrote %s: %lld events over %.0f s\n", out.c_str(),
               static_cast<long long>(w.n), duration);
  return 0;
}
