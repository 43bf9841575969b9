// mqtt_bus_publish: publishes the LCM messages mqtt_live_netns.sh checks on MQTT, with values
// the checker (mqtt_check.py) knows. Nobody publishes zone_event_t or alert_t yet (ips-zones will),
// so the test makes them here. Uses LCM_DEFAULT_URL.
//
//   mqtt_bus_publish pose CHANNEL TAG FIRST COUNT HZ
//       COUNT poses numbered FIRST.. (num_used = the number), HZ a second (0: at once): utime the
//       wall time of publishing, source "test", position (n * 0.01, 2.5, 1.2), covariance
//       [[0.04, 0.01, 0], [0.01, 0.01, 0], [0, 0, 0.09]], velocity (0.5, 0, NaN), heading
//       pi/2, residual 0.05 m, status OK | 2D. Prints "published N poses in S s from UTIME"
//       (the wall time of the first, us).
//   mqtt_bus_publish zone TAG ZONE_ID EVENT SEQ     (EVENT 1 enter, 2 leave, 3 dwell)
//       utime 1764700000000000 + SEQ, zone name "Zone <ZONE_ID>", floor 1 (ZONE_ID "any":
//       FLOOR_ANY), dwell_s 12.5, position (3, 4, 1.2), pose_channel POSE_FUSED, alert = SEQ odd.
//   mqtt_bus_publish alert SEQ STATE                (STATE 1 raised, 2 cleared)
//       utime 1764700000000000 + SEQ, id 7, kind zone, severity critical, subject "T1/Z1",
//       text "T1 entered Z1 (restricted)".
//   mqtt_bus_publish health SOURCE STATE
//       a health_t of process SOURCE in STATE, msgs_in 42, last_error "disk full", note "a note".
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ips/alert_t.hpp>
#include <ips/health_t.hpp>
#include <ips/pose_t.hpp>
#include <ips/zone_event_t.hpp>
#include <lcm/lcm-cpp.hpp>
#include <string>
#include <thread>

namespace {

int64_t wall_utime() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

constexpr int64_t kBaseUtime = 1764700000000000;

int usage() {
  std::fprintf(stderr,
               "usage: mqtt_bus_publish pose CHANNEL TAG FIRST COUNT HZ | zone TAG ZONE EVENT SEQ "
               "| alert SEQ STATE | health SOURCE STATE\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) return usage();
  lcm::LCM lcm;
  if (!lcm.good()) {
    std::fprintf(stderr, "mqtt_bus_publish: cannot open LCM\n");
    return 1;
  }
  const std::string what = argv[1];
  if (what == "pose" && argc == 7) {
    const std::string channel = argv[2];
    const long first = std::atol(argv[4]), count = std::atol(argv[5]);
    const double hz = std::atof(argv[6]);
    const auto start = std::chrono::steady_clock::now();
    const int64_t start_utime = wall_utime();
    for (long i = 0; i < count; ++i) {
      if (hz > 0)
        std::this_thread::sleep_until(
            start + std::chrono::duration_cast<std::chrono::nanoseconds>(
                        std::chrono::duration<double>(static_cast<double>(i) / hz)));
      const long n = first + i;
      ips::pose_t p{};
      p.utime = wall_utime();
      p.source = "test";
      p.tag_id = argv[3];
      p.position[0] = static_cast<double>(n) * 0.01;
      p.position[1] = 2.5;
      p.position[2] = 1.2;
      const double cov[9] = {0.04, 0.01, 0, 0.01, 0.01, 0, 0, 0, 0.09};
      for (int k = 0; k < 9; ++k) p.position_cov[k] = cov[k];
      p.velocity[0] = 0.5;
      p.velocity[1] = 0;
      p.velocity[2] = NAN;
      p.heading_rad = M_PI / 2;
      p.num_used = static_cast<int32_t>(n);
      p.residual_m = 0.05;
      p.status = int32_t{ips::pose_t::STATUS_OK} | ips::pose_t::STATUS_2D;
      if (lcm.publish(channel, &p) != 0) return 1;
    }
    std::printf("published %ld poses in %.3f s from %lld\n", count,
                std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(),
                static_cast<long long>(start_utime));
    return 0;
  }
  if (what == "zone" && argc == 6) {
    const std::string zone = argv[3];
    const long seq = std::atol(argv[5]);
    ips::zone_event_t e{};
    e.utime = kBaseUtime + seq;
    e.source = "ips-zones";
    e.seq = seq;
    e.tag_id = argv[2];
    e.zone_id = zone;
    e.zone_name = "Zone " + zone;
    e.floor = zone == "any" ? ips::zone_event_t::FLOOR_ANY : 1;
    e.event = static_cast<int8_t>(std::atoi(argv[4]));
    e.dwell_s = 12.5;
    e.position[0] = 3;
    e.position[1] = 4;
    e.position[2] = 1.2;
    e.pose_channel = "POSE_FUSED";
    e.alert = seq % 2 == 1;
    return lcm.publish("ZONE_EVENT", &e) == 0 ? 0 : 1;
  }
  if (what == "alert" && argc == 4) {
    const long seq = std::atol(argv[2]);
    ips::alert_t a{};
    a.utime = kBaseUtime + seq;
    a.source = "ips-zones";
    a.seq = seq;
    a.id = 7;
    a.kind = ips::alert_t::KIND_ZONE;
    a.severity = ips::alert_t::SEVERITY_CRITICAL;
    a.state = static_cast<int8_t>(std::atoi(argv[3]));
    a.subject = "T1/Z1";
    a.text = "T1 entered Z1 (restricted)";
    return lcm.publish("ALERT", &a) == 0 ? 0 : 1;
  }
  if (what == "health" && argc == 4) {
    ips::health_t h{};
    h.utime = wall_utime();
    h.source = argv[2];
    h.host = "test-host";
    h.pid = 4242;
    h.state = static_cast<int8_t>(std::atoi(argv[3]));
    h.msgs_in = 42;
    h.last_error = "disk full";
    h.uptime_us = 3500000;
    h.recv_buf_bytes = -1;
    h.version = "0.1.0 (test)";
    h.note = "a note";
    return lcm.publish("HEALTH", &h) == 0 ? 0 : 1;
  }
  return usage();
}
