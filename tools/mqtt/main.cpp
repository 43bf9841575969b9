// ips-mqtt: a bridge from the LCM bus to an MQTT broker (issue 24 item 5). Poses, zone events,
// alerts and HEALTH become JSON on ips/<site>/... topics (docs/mqtt.md); the broker's network runs
// in its own thread (tools/mqtt/broker_link.hpp) so that the LCM loop never waits for it.
#include <spdlog/spdlog.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <ips/alert_t.hpp>
#include <ips/health_t.hpp>
#include <ips/pose_t.hpp>
#include <ips/zone_event_t.hpp>
#include <stdexcept>
#include <thread>

#include "core/channels.hpp"
#include "core/cli.hpp"
#include "core/node.hpp"
#include "core/site_source.hpp"
#include "core/text_escape.hpp"
#include "core/time.hpp"
#include "core/yaml_fields.hpp"
#include "tools/mqtt/broker_link.hpp"
#include "tools/mqtt/mqtt_mapping.hpp"

namespace {

constexpr const char* kProgram = "ips-mqtt";
namespace mq = ips::mqtt;

int usage(const std::string& what) {
  ips::print_fatal(kProgram, what);
  return 2;
}

// Only these stay on this machine: anything else may cross a network.
bool is_loopback(const std::string& host) {
  return host == "localhost" || host == "ip6-localhost" || host == "::1" ||
         host.rfind("127.", 0) == 0;
}

std::string utc_text(std::chrono::system_clock::time_point t) {
  const time_t secs = std::chrono::system_clock::to_time_t(t);
  std::tm tm{};
  gmtime_r(&secs, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

// The password: the first line of --password-file, else IPS_MQTT_PASSWORD; never argv (ps shows
// it to every user of the machine).
bool read_password(const std::string& file, std::string& password, std::string& error) {
  if (file.empty()) {
    if (const char* env = std::getenv("IPS_MQTT_PASSWORD")) password = env;
    return true;
  }
  try {
    std::string text = ips::read_text_file(file);
    password = text.substr(0, text.find('\n'));
    if (!password.empty() && password.back() == '\r') password.pop_back();
  } catch (const ips::ConfigError& e) {
    error = std::string("--password-file: ") + e.what();
    return false;
  }
  if (password.empty()) {
    error = "--password-file: '" + ips::printable(file) + "' holds no password on its first line";
    return false;
  }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "ips-mqtt: bridges the LCM bus to an MQTT broker: poses (rate-limited per tag), "
      "zone events, alerts and every process's HEALTH as JSON on "
      "<prefix>/<site>/tag/<tag>/pose, .../tag/<tag>/zone, <prefix>/<site>/alert and "
      "<prefix>/<site>/health/<process> (docs/mqtt.md). Reconnects by itself with a "
      "back-off; while the broker is away it counts what it could not send and is "
      "degraded in HEALTH.",
      kProgram};
  app.footer(
      "Example (a broker on this machine; watch it with mosquitto_sub):\n"
      "  ips-mqtt --max-pose-hz 2\n"
      "  mosquitto_sub -t 'ips/#' -v\n"
      "See docs/programs/ips-mqtt.md and docs/mqtt.md.");
  ips::CommonOptions opts;
  ips::add_common_options(app, opts);
  mq::BrokerOptions broker;
  std::vector<std::string> pose_channels;
  std::string site_name, topic_prefix = "ips", password_file;
  double max_pose_hz = 5;
  bool retain_health = false;
  app.add_option("--pose-channel", pose_channels,
                 "pose channels to bridge, comma-separated or repeated (default POSE_FUSED)")
      ->delimiter(',')
      ->type_name("CHANNEL");
  app.add_option("--site-name", site_name,
                 "the <site> of the topics (default: the name of the site on SITE or --site; "
                 "\"default\" until one is known)");
  app.add_option("--topic-prefix", topic_prefix, "first level(s) of every topic")
      ->capture_default_str();
  app.add_option("--max-pose-hz", max_pose_hz,
                 "poses per second per tag and channel at most (0: every pose)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1000.0));
  app.add_option("--qos", broker.qos, "MQTT quality of service of every message (0 or 1)")
      ->capture_default_str()
      ->check(CLI::Range(0, 1));
  app.add_flag("--retain-health", retain_health,
               "publish HEALTH retained (a new subscriber gets each process's last report)");
  app.add_option("--host", broker.host, "the broker's host name or address")->capture_default_str();
  app.add_option("--port", broker.port, "the broker's port")
      ->capture_default_str()
      ->check(CLI::Range(1, 65535));
  app.add_option("--client-id", broker.client_id,
                 "MQTT client id (default ips-mqtt-<hostname>-<pid>)");
  app.add_option("--keepalive", broker.keepalive_s, "seconds between MQTT keep-alive pings")
      ->capture_default_str()
      ->check(CLI::Range(5, 65535));
  app.add_option("--username", broker.username, "MQTT user name");
  app.add_option("--password-file", password_file,
                 "file whose first line is the MQTT password (else env IPS_MQTT_PASSWORD; never "
                 "on the command line)")
      ->type_name("FILE");
  app.add_option("--cafile", broker.cafile,
                 "CA certificate(s) (PEM) the broker's certificate is checked against: TLS on")
      ->type_name("FILE");
  app.add_option("--cert", broker.certfile, "client certificate (PEM) for TLS client auth")
      ->type_name("FILE");
  app.add_option("--key", broker.keyfile, "the client certificate's private key (PEM)")
      ->type_name("FILE");
  app.add_flag("--tls-insecure", broker.tls_insecure,
               "do not check the broker certificate's host name (testing only)");
  app.add_option("--reconnect-min", broker.reconnect_min_s,
                 "seconds before the first reconnection attempt; doubles after each failure")
      ->capture_default_str()
      ->check(CLI::Range(0.1, 3600.0));
  app.add_option("--reconnect-max", broker.reconnect_max_s,
                 "seconds between reconnection attempts at most")
      ->capture_default_str()
      ->check(CLI::Range(0.1, 3600.0));
  int rc = 0;
  if (!ips::parse_command_line(app, opts, argc, argv, rc)) return rc;

  if (pose_channels.empty()) pose_channels.push_back(opts.channel(ips::channel::kPoseFused));
  for (const auto& c : pose_channels)
    if (!ips::channel::valid_channel_name(c))
      return usage("--pose-channel: '" + ips::printable(c) +
                   "' is not a channel name (1 to 63 of A-Z a-z 0-9 _)");
  if (const std::string why = mq::check_topic_prefix(topic_prefix); !why.empty())
    return usage("--topic-prefix '" + ips::printable(topic_prefix) + "': " + why);
  if (app.count("--site-name") && site_name.empty()) return usage("--site-name: empty");
  if (broker.host.empty()) return usage("--host: empty");
  if (broker.reconnect_max_s < broker.reconnect_min_s)
    return usage("--reconnect-max: less than --reconnect-min");
  if (broker.certfile.empty() != broker.keyfile.empty())
    return usage("--cert and --key go together");
  if (!broker.certfile.empty() && broker.cafile.empty())
    return usage("--cert needs --cafile (TLS)");
  if (broker.tls_insecure && broker.cafile.empty()) return usage("--tls-insecure needs --cafile");
  // libmosquitto says only "Invalid function arguments" of a file it cannot read.
  for (const auto& [flag, file] :
       {std::pair<const char*, const std::string&>{"--cafile", broker.cafile},
        {"--cert", broker.certfile},
        {"--key", broker.keyfile}}) {
    if (file.empty()) continue;
    try {
      (void)ips::read_text_file(file);
    } catch (const ips::ConfigError& e) {
      return usage(std::string(flag) + ": " + e.what());
    }
  }
  if (!password_file.empty() && broker.username.empty())
    return usage("--password-file needs --username");
  if (std::string error; !read_password(password_file, broker.password, error)) return usage(error);
  if (!is_loopback(broker.host) && broker.cafile.empty())
    std::fprintf(stderr,
                 "%s: warning: --host %s is not this machine and TLS is off (--cafile): "
                 "positions%s cross the network in clear\n",
                 kProgram, ips::printable(broker.host).c_str(),
                 broker.username.empty() ? "" : " and the password");

  return ips::run_reporting_errors(kProgram, [&] {
    ips::Node node(kProgram, opts);
    std::unique_ptr<mq::BrokerLink> link;
    try {
      link = std::make_unique<mq::BrokerLink>(broker);
    } catch (const std::runtime_error& e) {
      return usage(e.what());
    }
    const std::string address = link->address();

    // The <site> level: --site-name, else the site's name once one is known.
    std::string site = site_name.empty() ? "default" : site_name;
    auto note_site = [&](const std::string& from) {
      node.report_note("site", "topics under " + topic_prefix + "/" + mq::topic_level(site) +
                                   " (site '" + site + "' " + from + ")");
    };
    if (!site_name.empty()) {
      note_site("from --site-name");
    } else {
      note_site("until a site is known: none on SITE yet");
      ips::provide_site(node, [&](const ips::Site& s) {
        if (s.name == site) return;
        site = s.name;
        note_site(opts.site_path.empty() ? "from SITE" : "from --site");
        spdlog::info("{}: site '{}': topics under {}/{}", kProgram, ips::printable(site),
                     topic_prefix, mq::topic_level(site));
      });
      node.set_state(ips::health_t::STATE_OK);  // bridging already, under "default"
    }

    // What could not be sent while the broker was away, since when.
    bool away = false;
    std::chrono::system_clock::time_point away_since = std::chrono::system_clock::now();
    int64_t sent_total = 0, unsent_while_away = 0, unsent_total = 0, queue_full = 0;
    std::string away_reason;
    auto say_away = [&] {
      node.report_lasting_error(
          "broker", "broker " + address + " unreachable since " + utc_text(away_since) + ": " +
                        std::to_string(unsent_while_away) + " messages not sent" +
                        (away_reason.empty() ? "" : " (" + away_reason + ")"));
    };
    auto send = [&](const std::string& topic, const std::string& payload, bool retain) {
      switch (link->publish(topic, payload, retain)) {
        case mq::BrokerLink::Sent::kQueued:
          ++node.counters().msgs_out;
          ++sent_total;
          return;
        case mq::BrokerLink::Sent::kNotConnected:
          ++node.counters().drops;
          ++unsent_while_away;
          ++unsent_total;
          return;
        case mq::BrokerLink::Sent::kQueueFull:
          ++node.counters().drops;
          ++queue_full;
          node.report_error(
              "broker " + address + " reads too slowly: " + std::to_string(queue_full) +
              " messages not sent (" + std::to_string(broker.max_queued) + " waiting)");
          return;
        case mq::BrokerLink::Sent::kRefused:
          ++node.counters().drops;
          node.report_error("topic " + ips::printable(topic) + ": refused by libmosquitto (" +
                            std::to_string(payload.size()) + " bytes)");
          return;
      }
    };
    auto take_events = [&] {
      for (const auto& e : link->take_events()) {
        if (e.connected) {
          if (away) {
            say_away();  // last_error keeps the outage's final count
            spdlog::info(
                "{}: broker {}: connected again after {:.1f} s; {} messages not sent "
                "meanwhile",
                kProgram, address, std::chrono::duration<double>(e.at - away_since).count(),
                unsent_while_away);
          } else {
            spdlog::info("{}: broker {}: connected", kProgram, address);
          }
          away = false;
          away_reason.clear();
          unsent_while_away = 0;
          node.end_lasting_error("broker");
        } else {
          if (!away) {
            // Counted from the loss, which the link saw before this event was taken.
            away = true;
            away_since = e.at;
            away_reason = e.reason;
            spdlog::warn("{}: broker {}: {}; retrying after {:g} s, then {:g} s, ... up to {:g} s",
                         kProgram, address, ips::printable(e.reason), broker.reconnect_min_s,
                         std::min(2 * broker.reconnect_min_s, broker.reconnect_max_s),
                         broker.reconnect_max_s);
            say_away();
          }
          away_reason = e.reason;  // the newest reason, said once a second
        }
      }
    };

    mq::PoseRateLimiter limiter(max_pose_hz);
    auto send_pose = [&](const ips::pose_t& p, const std::string& channel) {
      send(mq::pose_topic(topic_prefix, site, p.tag_id), mq::pose_json(p, channel), false);
    };
    for (const auto& channel : pose_channels)
      node.subscribe<ips::pose_t>(channel, [&](const ips::pose_t& p, const std::string& ch) {
        if (limiter.admit(p, ch, ips::wall_utime_now())) send_pose(p, ch);
      });
    node.subscribe<ips::zone_event_t>(opts.channel(ips::channel::kZoneEvent),
                                      [&](const ips::zone_event_t& e, const std::string&) {
                                        send(mq::zone_topic(topic_prefix, site, e.tag_id),
                                             mq::zone_json(e), false);
                                      });
    node.subscribe<ips::alert_t>(
        opts.channel(ips::channel::kAlert), [&](const ips::alert_t& a, const std::string&) {
          send(mq::alert_topic(topic_prefix, site), mq::alert_json(a), false);
        });
    node.subscribe<ips::health_t>(
        opts.channel(ips::channel::kHealth), [&](const ips::health_t& h, const std::string&) {
          send(mq::health_topic(topic_prefix, site, h.source), mq::health_json(h), retain_health);
        });

    // Held poses go once their tag's interval has passed: a tenth of it late at most.
    if (max_pose_hz > 0)
      node.add_timer(std::min(0.05, 0.1 / max_pose_hz),
                     [&] { limiter.release(ips::wall_utime_now(), send_pose); });
    node.add_timer(0.1, take_events);
    node.add_timer(1.0, [&] {
      take_events();
      if (!link->connected()) {
        away = true;  // not connected yet at start, or lost between two events
        say_away();
      }
      if (max_pose_hz > 0)
        node.report_note("rate",
                         "poses at most " + fmt::format("{:g}", max_pose_hz) +
                             " Hz per tag and channel: " + std::to_string(limiter.rate_limited()) +
                             " merged into later ones");
    });
    std::string channels;
    for (const auto& c : pose_channels) channels += c + ", ";
    spdlog::info("{}: bridging {}{}, {}, {} to the broker {} (QoS {}{}), topics {}/{}/...",
                 kProgram, channels, opts.channel(ips::channel::kZoneEvent),
                 opts.channel(ips::channel::kAlert), opts.channel(ips::channel::kHealth), address,
                 broker.qos, broker.cafile.empty() ? ", no TLS" : ", TLS", topic_prefix,
                 mq::topic_level(site));
    link->start();
    // A broker on this machine answers within milliseconds: wait for it (at most 2 s) so that
    // the first messages, our own first HEALTH among them, are not lost to the start.
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(2);
    while (!link->connected() && std::chrono::steady_clock::now() < give_up)
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    const int status = node.run();
    spdlog::info(
        "{}: {} messages sent, {} not sent (broker away), {} poses merged by the rate "
        "limit",
        kProgram, sent_total, unsent_total, limiter.rate_limited());
    return status;
  });
}
