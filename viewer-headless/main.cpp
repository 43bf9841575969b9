// ips-view: the headless web dashboard. Serves a live page (floor map with anchors, every tag's
// estimates with covariance ellipses and trails, a channel table, process health) for the bus or
// for a log played at its own pace, and renders a log or a live snapshot to SVG or PNG.
//
//   ips-view                          the live bus on http://127.0.0.1:8080/
//   ips-view --bind 0.0.0.0           the same, reachable from other machines
//   ips-view LOG [--speed 4]          a log, played into the page (--speed 0: all at once)
//   ips-view render LOG --out map.svg [--at S]   the map at S seconds into the log (default: end)
//   ips-view render --live 3 --out map.png       the map after listening to the bus for 3 s
//   ips-view render --live 3 --wait-site 30 ...  the same, listening on (at most 30 s more)
//                                                until a SITE message has come
//   ips-view render --live 3 --wait-site 30 --min-tracks 4 ...  and until 4 tracks (a tag on
//                                                one channel) are on the map
//
// HTTP (docs/viewer.md): GET / (the page), /view.js, /view.css, /api/state (JSON snapshot;
// ?trails=0 without trails), /api/info, /map.svg, and /events (Server-Sent Events: "state" and
// "map" a few times a second). Everything is served by this process: no internet needed.
#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <functional>
#include <limits>
#include <lcm/lcm-cpp.hpp>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "core/channels.hpp"
#include "core/cli.hpp"
#include "core/device_text.hpp"
#include "core/error_limiter.hpp"
#include "core/http_server.hpp"
#include "core/log_input.hpp"
#include "core/log_reader.hpp"
#include "core/node.hpp"
#include "core/site.hpp"
#include "core/svg_text.hpp"
#include "core/text_escape.hpp"
#include "core/time.hpp"
#include "core/yaml_fields.hpp"
#include "viewer-headless/bus_feed.hpp"
#include "viewer-headless/png_output.hpp"
#include "viewer-headless/svg_render.hpp"
#include "viewer-headless/view_model.hpp"
#include "viewer-headless/web_assets.hpp"

namespace {

constexpr const char* kProgram = "ips-view";

using ips::utime_t;
using ips::view::BusFeed;
using ips::view::ViewModel;

struct MapOptions {
  double width_px = 900;
  double height_px = 700;
  double sigma = 2.0;
  bool no_trails = false;
  std::string title;

  ips::view::SvgOptions svg() const {
    ips::view::SvgOptions o;
    o.max_width_px = width_px;
    o.max_height_px = height_px;
    o.ellipse_sigma = sigma;
    o.trails = !no_trails;
    o.title = title;
    return o;
  }
};

struct ServeOptions {
  std::string log;
  std::string bind = "127.0.0.1";
  int port = 8080;
  double speed = 1.0;
  double update_hz = 4.0;
  size_t max_clients = 32;
  size_t max_clients_per_peer = 8;
  double header_timeout_s = 2.0;
};

struct RenderOptions {
  std::string log;
  double live_s = 0;
  double wait_site_s = 0;  // with live_s: listen up to this much longer for a SITE message
  size_t min_tracks = 0;   // with wait_site_s: and for this many tracks (tag and channel)
  std::string out;
  double at_s = -1;  // < 0: the end of the log
  double zoom = 1.0;
  bool force = false;
  int floor = ips::kNoFloor;  // --floor: that floor's plan, zones and tracks
};

ips::view::FeedChannels feed_channels(const ips::CommonOptions& opts) {
  ips::view::FeedChannels c;
  // With --site the map's site is that file's: SITE messages are not taken.
  c.site = opts.site_path.empty() ? opts.channel(ips::channel::kSite) : "";
  c.health = opts.channel(ips::channel::kHealth);
  c.altitude = opts.channel(ips::channel::kAltitude);
  c.zone_event = opts.channel(ips::channel::kZoneEvent);
  c.alert = opts.channel(ips::channel::kAlert);
  return c;
}

// --site: the map's site from a file (a bad file ends the program with one line, status 2).
void pin_site(ViewModel& model, const ips::CommonOptions& opts) {
  if (opts.site_path.empty()) return;
  const ips::Site site = ips::load_site_file(opts.site_path);
  const utime_t now = ips::wall_utime_now();
  model.on_site(ips::site_to_msg(site, now, "--site " + opts.site_path), now);
}

// Every message on the bus into the feed, with the host time LCM received it; a SITE or
// HEALTH message that is not its type is a parse error in this process's HEALTH.
void feed_from_bus(ips::Node& node, BusFeed& feed) {
  node.subscribe_raw(".*", [&node, &feed](const lcm::ReceiveBuffer* rbuf,
                                         const std::string& channel) {
    if (const char* type = feed.feed(channel, rbuf->data, static_cast<size_t>(rbuf->data_size),
                                     rbuf->recv_utime)) {
      ++node.counters().parse_errors;
      node.report_error("channel " + ips::printable(channel) + ": a message that is not a " +
                        type);
    }
  });
}

// A log fed into the model at its own pace: event k when (t_k - t_0) / speed has passed since
// the start (speed <= 0: all at once, in the constructor). The model's clock is the log's.
// until_s >= 0 stops before the first event more than until_s after the first (cut()).
class LogPlayback {
 public:
  // done_text: what LogInput::finish() says is done with what was read.
  LogPlayback(std::unique_ptr<ips::LogInput> in, BusFeed& feed, double speed,
              std::string done_text, double until_s = -1)
      : in_(std::move(in)),
        feed_(feed),
        speed_(speed),
        until_s_(until_s),
        done_text_(std::move(done_text)),
        start_(Clock::now()) {
    if (speed_ <= 0) advance();
  }

  // Stops the clock where it is / starts it again; a new speed from here.
  void pause() {
    base_s_ = elapsed_log_s();
    paused_ = true;
  }
  void play() {
    if (!paused_) return;
    start_ = Clock::now();
    paused_ = false;
  }
  void set_speed(double speed) {
    base_s_ = elapsed_log_s();
    start_ = Clock::now();
    speed_ = speed;
  }
  bool paused() const { return paused_; }
  double speed() const { return speed_; }
  // Log seconds since the first event that the page shows.
  double position_s() const {
    if (!first_) return 0.0;
    if (done_ || speed_ <= 0) return seconds();
    return std::max(seconds(), elapsed_log_s());
  }
  // Jumps ahead to `to_s` log seconds after the first event: everything before it at once (a
  // jump back is a new playback of the log: see serve()).
  void skip_to(double to_s) {
    base_s_ = std::max(to_s, 0.0);
    start_ = Clock::now();
    advance();
  }

  // Feeds every event due now.
  void advance() {
    if (done_) return;
    if (pending_) {
      if (!due(pending_->utime)) return;
      take(pending_->channel, pending_->data.data(), pending_->data.size(), pending_->utime);
      pending_.reset();
    }
    while (const ips::LogEvent* e = in_->next()) {
      if (!first_) first_ = last_ = e->timestamp_us;
      if (until_s_ >= 0 && ips::view::seconds_between(e->timestamp_us, *first_) > until_s_) {
        cut_ = done_ = true;
        return;
      }
      if (!due(e->timestamp_us)) {
        pending_ = Event{e->channel, std::vector<uint8_t>(e->data, e->data + e->size),
                         e->timestamp_us};
        return;
      }
      take(e->channel, e->data, e->size, e->timestamp_us);
    }
    done_ = true;
    readable_ = in_->finish(done_text_);
  }

  // The log time the page shows: the playback's cursor, or the last event's time at the end.
  utime_t now() const {
    if (done_ || speed_ <= 0 || !first_) return last_;
    return std::max(last_, cursor());
  }
  bool done() const { return done_; }
  // Stopped at until_s, before the end of the log.
  bool cut() const { return cut_; }
  // False when the file held bytes but no event (LogInput::finish() has said so).
  bool readable() const { return readable_; }
  int64_t events() const { return events_; }
  // From the first event to the last one fed.
  double seconds() const { return first_ ? ips::view::seconds_between(last_, *first_) : 0.0; }

 private:
  using Clock = std::chrono::steady_clock;
  struct Event {
    std::string channel;
    std::vector<uint8_t> data;
    utime_t utime;
  };
  void take(const std::string& channel, const uint8_t* data, size_t size, utime_t utime) {
    feed_.feed(channel, data, size, utime);
    last_ = std::max(last_, utime);
    ++events_;
  }
  bool due(utime_t utime) const {
    return speed_ <= 0 || ips::view::seconds_between(utime, *first_) <= elapsed_log_s();
  }
  // Log seconds since the first event that the playback has reached.
  double elapsed_log_s() const {
    if (paused_) return base_s_;
    return base_s_ + std::chrono::duration<double>(Clock::now() - start_).count() * speed_;
  }
  // The log time reached (saturating: log times are not trusted).
  utime_t cursor() const {
    utime_t t = 0;
    if (__builtin_add_overflow(*first_, ips::s_to_utime(elapsed_log_s()), &t))
      t = std::numeric_limits<utime_t>::max();
    return t;
  }

  std::unique_ptr<ips::LogInput> in_;
  BusFeed& feed_;
  double speed_;
  double until_s_;
  std::string done_text_;
  Clock::time_point start_;
  std::optional<utime_t> first_;
  std::optional<Event> pending_;
  utime_t last_ = 0;
  int64_t events_ = 0;
  bool done_ = false;
  bool cut_ = false;
  bool readable_ = true;
  bool paused_ = false;
  double base_s_ = 0;  // log seconds reached when start_ was taken
};

// The first and last event times of a log (its head and tail, no decoding): the page's timeline.
std::pair<utime_t, utime_t> log_span(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) return {0, 0};
  const std::optional<ips::LogSpan> span = ips::read_log_span(f);
  std::fclose(f);
  if (!span) return {0, 0};
  return {span->first_us, span->last_us};
}

bool loopback_address(const std::string& addr) { return addr.rfind("127.", 0) == 0; }

std::string host_name() {
  char name[256] = {};
  if (::gethostname(name, sizeof name - 1) != 0 || name[0] == '\0') return "this-machine";
  return name;
}

int serve(ips::CommonOptions opts, const ServeOptions& so, const MapOptions& mo) {
  const bool from_log = !so.log.empty();
  // A log is shown, not republished: the process's own HEALTH stays off the LAN.
  if (from_log && opts.lcm_url.empty()) opts.lcm_url = "memq://";
  ips::Node node(kProgram, opts);
  ViewModel model;
  BusFeed feed(model, feed_channels(opts));
  pin_site(model, opts);

  std::unique_ptr<LogPlayback> playback;
  std::pair<utime_t, utime_t> span{0, 0};
  // (Re)starts the log's playback from its beginning into a fresh model.
  const auto start_playback = [&]() -> bool {
    auto in = ips::LogInput::open(kProgram, so.log);
    if (!in) return false;
    const double speed = playback ? playback->speed() : so.speed;
    const bool paused = playback && playback->paused();
    model = ViewModel(model.options());
    pin_site(model, opts);
    playback = std::make_unique<LogPlayback>(std::move(in), feed, speed, "showing what was read");
    if (paused) playback->pause();
    return true;
  };
  if (from_log) {
    if (!start_playback()) return 2;
    span = log_span(so.log);
    bool announced = false;
    node.add_timer(0.02, [&, announced]() mutable {
      playback->advance();
      if (!playback->done() || announced) return;
      announced = true;
      std::fprintf(stderr,
                   "%s: end of the log: %lld events over %.1f s; still serving its last state\n",
                   kProgram, static_cast<long long>(playback->events()), playback->seconds());
    });
  } else {
    feed_from_bus(node, feed);
  }
  // What the model could not keep (full tables, overlong ids, non-finite positions) shows in
  // HEALTH as drops, with the counts in last_error.
  int64_t reported_drops = 0;
  node.add_timer(1.0, [&] {
    const ips::view::ViewStats& v = model.stats();
    const int64_t drops = v.dropped_long_ids + v.dropped_too_many_tracks +
                          v.dropped_too_many_channels + v.dropped_too_many_processes +
                          v.non_finite_positions + v.bad_sites;
    if (drops == reported_drops) return;
    node.counters().drops += drops - reported_drops;
    reported_drops = drops;
    node.report_error("not shown: " + std::to_string(v.dropped_too_many_tracks) +
                      " poses beyond the track limit, " +
                      std::to_string(v.dropped_too_many_channels) + " messages beyond the channel "
                      "limit, " + std::to_string(v.dropped_too_many_processes) +
                      " HEALTH beyond the process limit, " + std::to_string(v.dropped_long_ids) +
                      " overlong ids, " + std::to_string(v.non_finite_positions) +
                      " non-finite positions, " + std::to_string(v.bad_sites) + " bad sites");
  });
  const auto now = [&]() -> utime_t { return playback ? playback->now() : ips::wall_utime_now(); };

  namespace http = ips::http;
  http::HttpServerOptions ho;
  ho.addr = so.bind;
  ho.port = static_cast<uint16_t>(so.port);
  ho.max_connections = so.max_clients;
  ho.max_connections_per_peer = so.max_clients_per_peer;
  ho.header_timeout_s = so.header_timeout_s;
  ho.limits.max_body_bytes = 4096;  // every route is a GET
  int64_t refused = 0;
  ips::ErrorLimiter http_limiter;
  std::unique_ptr<http::HttpServer> server_owner;
  server_owner = std::make_unique<http::HttpServer>(
      node, ho,
      http::HttpServer::Callbacks{
          .on_refused = [&](int status, const std::string& reason, const std::string& peer) {
            ++refused;
            spdlog::debug("HTTP {} to {}: {}", status, peer, ips::printable(reason));
            // Connections cut (408: slow, silent or evicted; 503: no slot) are drops in HEALTH.
            // One that sent nothing at all is only counted: browsers open spare connections
            // they may never use.
            if (status != 408 && status != 503) return;
            ++node.counters().drops;
            if (reason.starts_with("no request after")) return;
            if (auto line = http_limiter.admit(
                    "http", "HTTP " + std::to_string(status) + " to " + peer + ": " + reason +
                                " (connections so far: " +
                                http::stats_text(server_owner->stats()) + ")",
                    ips::wall_utime_now()))
              node.report_error(*line);
          }});
  http::HttpServer& server = *server_owner;

  // The page may load only what ips-view serves: even a string that escaped escaping could not
  // run as a script.
  const std::string page_headers =
      "Content-Security-Policy: default-src 'self'; script-src 'self'; style-src 'self' "
      "'unsafe-inline'; img-src 'self' data:; connect-src 'self'; object-src 'none'; base-uri "
      "'none'; frame-ancestors 'none'\r\nX-Content-Type-Options: nosniff\r\nReferrer-Policy: "
      "no-referrer\r\nCache-Control: no-cache\r\n";
  const std::string data_headers = "Cache-Control: no-store\r\nX-Content-Type-Options: nosniff\r\n";
  // What an update costs this process (building the state and queueing it for every page),
  // for /api/info and the benchmark (scripts/bench-view).
  struct UpdateCost {
    int64_t count = 0;
    double last_ms = 0, max_ms = 0, sum_ms = 0;
  } cost;
  // The playback's place for the page's timeline (log mode; null live).
  const auto playback_json = [&]() -> std::string {
    if (!playback) return "null";
    const double duration = ips::view::seconds_between(span.second, span.first);
    return "{\"first_utime\":" + std::to_string(span.first) +
           ",\"duration_s\":" + ips::view::json_number(duration) +
           ",\"position_s\":" + ips::view::json_number(std::min(playback->position_s(), duration)) +
           ",\"speed\":" + ips::view::json_number(playback->speed()) +
           ",\"paused\":" + (playback->paused() ? "true" : "false") +
           ",\"done\":" + (playback->done() ? "true" : "false") + "}";
  };
  const auto info_json = [&]() {
    std::string j = "{\"program\":\"ips-view\",\"mode\":";
    j += from_log ? "\"log\"" : "\"live\"";
    j += ",\"log\":" + ips::view::json_string(so.log);
    j += ",\"speed\":" + ips::view::json_number(playback ? playback->speed() : so.speed);
    j += ",\"log_done\":";
    j += playback && playback->done() ? "true" : "false";
    j += ",\"playback\":" + playback_json();
    j += ",\"trail_s\":" + ips::view::json_number(model.options().trail_s);
    j += ",\"lcm_url\":" + ips::view::json_string(from_log ? "" : opts.lcm_url.empty()
                                                                       ? "(LCM default)"
                                                                       : opts.lcm_url);
    j += ",\"clients\":" + std::to_string(server.stream_count("/events"));
    j += ",\"http_refused\":" + std::to_string(refused);
    const http::HttpServerStats& hs = server.stats();
    j += ",\"http_connections\":{\"accepted\":" + std::to_string(hs.accepted) +
         ",\"refused\":" + std::to_string(hs.refused) + ",\"evicted\":" +
         std::to_string(hs.evicted) +
         ",\"evicted_readers\":" + std::to_string(hs.evicted_readers) +
         ",\"evicted_streams\":" + std::to_string(hs.evicted_streams) +
         ",\"header_timeouts\":" + std::to_string(hs.header_timeouts) +
         ",\"request_timeouts\":" + std::to_string(hs.request_timeouts) +
         ",\"idle_closed\":" + std::to_string(hs.idle_closed) +
         ",\"aborted\":" + std::to_string(hs.aborted) + "}";
    j += ",\"http_refusals\":{";  // by status
    const char* sep = "";
    for (const auto& [status, n] : hs.refusals) {
      j += sep + ("\"" + std::to_string(status) + "\":") + std::to_string(n);
      sep = ",";
    }
    j += "}";
    j += ",\"streams_dropped\":" + std::to_string(server.streams_dropped());
    j += ",\"update_ms\":{\"count\":" + std::to_string(cost.count) +
         ",\"last\":" + ips::view::json_number(cost.last_ms) +
         ",\"mean\":" + ips::view::json_number(cost.count ? cost.sum_ms / static_cast<double>(cost.count) : 0.0) +
         ",\"max\":" + ips::view::json_number(cost.max_ms) + "}}";
    return j;
  };
  for (const ips::view::WebAsset& a : ips::view::web_assets()) {
    if (a.path == "/") {
      // The page with the state of now in it, so it draws before any event arrives (a
      // screenshot, a slow link). json_string escapes < > &: no "</script>" can come out.
      server.route("GET", "/", [&](const http::HttpRequest&, const std::string&, utime_t) {
        std::string page(a.body);
        const std::string mark = "<!--initial-state-->";
        if (const auto at = page.find(mark); at != std::string::npos)
          page.replace(at, mark.size(),
                       "<script type=\"application/json\" id=\"initial-state\">{\"info\":" +
                           info_json() + ",\"site\":" + model.site_json() +
                           ",\"state\":" + model.json(now(), true) + "}</script>");
        return http::HttpReply{200, std::string(a.content_type), page, page_headers};
      });
      continue;
    }
    server.route("GET", std::string(a.path), [&a, &page_headers](const http::HttpRequest&,
                                                                  const std::string&, utime_t) {
      return http::HttpReply{200, std::string(a.content_type), std::string(a.body), page_headers};
    });
  }
  server.route("GET", "/api/state",
               [&](const http::HttpRequest& r, const std::string&, utime_t) {
                 const bool trails = r.query.find("trails=0") == std::string::npos;
                 return http::HttpReply{200, "application/json", model.json(now(), trails),
                                        data_headers};
               });
  server.route("GET", "/api/site", [&](const http::HttpRequest&, const std::string&, utime_t) {
    return http::HttpReply{200, "application/json", model.site_json(), data_headers};
  });
  server.route("GET", "/api/info", [&](const http::HttpRequest&, const std::string&, utime_t) {
    return http::HttpReply{200, "application/json", info_json(), data_headers};
  });
  const auto bad_request = [&](const std::string& reason) {
    return http::HttpReply{400, "application/json",
                           "{\"status\":\"error\",\"reason\":" +
                               ips::view::json_string(reason) + "}",
                           data_headers};
  };
  const auto param = [](const http::HttpRequest& r, const char* name) {
    auto v = http::query_param(r.query, name);
    return v ? v : http::query_param(r.body, name);
  };
  // POST /api/alerts/ack?source=S&id=N: someone at a page has seen the alert.
  server.route("POST", "/api/alerts/ack",
               [&](const http::HttpRequest& r, const std::string&, utime_t) {
                 const auto source = param(r, "source");
                 const auto id = param(r, "id");
                 int64_t n = 0;
                 if (!source || !id || !ips::parse_integer(*id, n))
                   return bad_request("expected source=PROCESS&id=N");
                 if (!model.ack_alert(*source, n))
                   return http::HttpReply{404, "application/json",
                                          "{\"status\":\"error\",\"reason\":\"no such alert\"}",
                                          data_headers};
                 return http::HttpReply{200, "application/json", "{\"status\":\"ok\"}",
                                        data_headers};
               });
  // POST /api/playback?action=pause|play|seek|speed[&t=S][&speed=X]: the log's timeline.
  server.route("POST", "/api/playback",
               [&](const http::HttpRequest& r, const std::string&, utime_t) {
                 if (!playback)
                   return http::HttpReply{409, "application/json",
                                          "{\"status\":\"error\",\"reason\":\"the live bus "
                                          "has no timeline\"}",
                                          data_headers};
                 const auto action = param(r, "action");
                 double x = 0;
                 if (action == "pause") {
                   playback->pause();
                 } else if (action == "play") {
                   playback->play();
                 } else if (action == "speed") {
                   const auto v = param(r, "speed");
                   if (!v || !ips::parse_decimal(*v, x) || !(x > 0 && x <= 1000))
                     return bad_request("speed: expected a number in (0, 1000]");
                   playback->set_speed(x);
                 } else if (action == "seek") {
                   const auto v = param(r, "t");
                   if (!v || !ips::parse_decimal(*v, x) || !(x >= 0 && x <= 1e9))
                     return bad_request("seek: expected t=SECONDS from the log's start");
                   // Back: the log again from its start, into a fresh model.
                   if (x < playback->position_s() && !start_playback())
                     return http::HttpReply{500, "application/json",
                                            "{\"status\":\"error\",\"reason\":\"cannot "
                                            "reopen the log\"}",
                                            data_headers};
                   playback->skip_to(x);
                 } else {
                   return bad_request("action: pause, play, seek or speed");
                 }
                 return http::HttpReply{200, "application/json", playback_json(), data_headers};
               });
  const ips::view::SvgOptions svg_options = mo.svg();
  server.route("GET", "/map.svg", [&](const http::HttpRequest&, const std::string&, utime_t) {
    return http::HttpReply{200, "image/svg+xml; charset=utf-8",
                           ips::view::render_svg(model, svg_options), data_headers};
  });
  server.route("GET", "/favicon.ico", [](const http::HttpRequest&, const std::string&, utime_t) {
    return http::HttpReply{204, "text/plain", "", ""};
  });
  // An update of the page: the snapshot without trails (the page keeps its own), and in log
  // mode the playback's place.
  const auto update = [&](const std::function<void(const char* event, const std::string&)>& send) {
    const auto t0 = std::chrono::steady_clock::now();
    send("state", model.json(now(), false, true));
    if (playback) send("playback", playback_json());
    cost.last_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
                       .count();
    cost.max_ms = std::max(cost.max_ms, cost.last_ms);
    cost.sum_ms += cost.last_ms;
    ++cost.count;
  };
  server.stream("/events", [&](http::HttpServer::StreamId id) {
    update([&](const char* event, const std::string& data) { server.send_event(id, event, data); });
  });
  node.add_timer(1.0 / so.update_hz, [&] {
    if (server.stream_count("/events") == 0) return;
    update([&](const char* event, const std::string& data) {
      server.broadcast("/events", event, data);
    });
  });

  std::string error;
  if (!server.open(error)) {
    ips::print_fatal(kProgram, error + (so.port != 0 ? " (another ips-view? choose --port)" : ""));
    return 1;
  }
  const std::string shown = so.bind == "0.0.0.0" ? host_name() : so.bind;
  std::fprintf(stderr, "%s: serving http://%s:%u/ (%s)\n", kProgram, shown.c_str(),
               server.bound_port(),
               from_log ? ("log " + so.log).c_str() : "live bus");
  if (!loopback_address(so.bind))
    std::fprintf(stderr,
                 "%s: warning: listening on %s: anyone who can reach this machine can see the "
                 "page (there is no login)\n",
                 kProgram, so.bind.c_str());
  const int rc = node.run();
  spdlog::info("{}: HTTP connections: {}", kProgram, http::stats_text(server.stats()));
  return rc;
}

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

int render(const ips::CommonOptions& opts, const RenderOptions& ro, const MapOptions& mo) {
  const bool png = ends_with(ro.out, ".png");
  if (!png && !ends_with(ro.out, ".svg")) {
    ips::print_fatal(kProgram, "--out '" + ro.out + "' must end in .svg or .png");
    return 2;
  }
  if (ro.log.empty() == (ro.live_s <= 0)) {
    ips::print_fatal(kProgram, "render: give either a LOG or --live SECONDS (see --help)");
    return 2;
  }
  if (ro.wait_site_s > 0 && ro.live_s <= 0) {
    ips::print_fatal(kProgram, "render: --wait-site goes with --live (a LOG has its own SITE)");
    return 2;
  }
  if (ro.min_tracks > 0 && ro.wait_site_s <= 0) {
    ips::print_fatal(kProgram, "render: --min-tracks goes with --wait-site (its bound)");
    return 2;
  }
  if (!ro.force && ::access(ro.out.c_str(), F_OK) == 0) {
    ips::print_fatal(kProgram, "'" + ro.out + "' exists (--force to overwrite)");
    return 2;
  }
  ViewModel model;
  BusFeed feed(model, feed_channels(opts));
  pin_site(model, opts);
  std::string when;
  if (!ro.log.empty()) {
    auto in = ips::LogInput::open(kProgram, ro.log);
    if (!in) return 2;
    const LogPlayback log(std::move(in), feed, 0, "rendering what was read", ro.at_s);
    if (!log.readable()) return 2;
    if (ro.at_s >= 0 && !log.cut())
      std::fprintf(stderr, "%s: warning: --at %g s is past the end of the log (%.1f s): rendering its end\n",
                   kProgram, ro.at_s, log.seconds());
    when = ips::svg::format("at %.1f s of the log", log.seconds());
  } else {
    ips::Node node(kProgram, opts);
    feed_from_bus(node, feed);
    const auto start = std::chrono::steady_clock::now();
    auto listened_s = [&] {
      return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    };
    bool waited = false;
    // What --wait-site waits for: a SITE, and --min-tracks tracks (a loaded machine or a
    // process starting late can take longer than --live S to show every estimate).
    const auto ready = [&] { return model.has_site() && model.tracks().size() >= ro.min_tracks; };
    if (ro.wait_site_s > 0) {
      // A simulator or a site server repeats SITE every few seconds: listen past --live until
      // one has come, for at most --wait-site more; the timer's period bounds the overshoot.
      node.add_timer(std::min(ro.live_s, 0.05), [&] {
        const double t = listened_s();
        if (t < ro.live_s) return;
        if (!ready() && t < ro.live_s + ro.wait_site_s) {
          waited = true;
          return;
        }
        node.stop();
      });
    } else {
      node.add_timer(ro.live_s, [&] { node.stop(); });
    }
    const int rc = node.run();
    if (rc != 0) return rc;
    if (node.stop_signal() != 0) return 0;  // interrupted: nothing written
    const double listened = listened_s();
    if (ro.wait_site_s > 0 && !model.has_site()) {
      ips::print_fatal(kProgram, fmt::format("no SITE message on {} within {:.1f} s (--live {:g}, "
                                             "--wait-site {:g}): nothing written",
                                             opts.channel(ips::channel::kSite), listened,
                                             ro.live_s, ro.wait_site_s));
      return 1;
    }
    if (model.tracks().size() < ro.min_tracks) {
      ips::print_fatal(kProgram, fmt::format("{} of --min-tracks {} tracks on the map within {:.1f} s "
                                             "(--live {:g}, --wait-site {:g}): nothing written",
                                             model.tracks().size(), ro.min_tracks, listened,
                                             ro.live_s, ro.wait_site_s));
      return 1;
    }
    when = waited ? fmt::format("after {:.1f} s of the live bus (waited for the site{})", listened,
                                ro.min_tracks > 0 ? " and the tracks" : "")
                  : ips::svg::format("after %g s of the live bus", ro.live_s);
  }

  ips::view::SvgOptions svg_options = mo.svg();
  svg_options.time_text = when;
  svg_options.floor = ro.floor;
  const std::string svg = ips::view::render_svg(model, svg_options);
  std::string error;
  if (png) {
    if (!ips::view::svg_to_png(svg, ro.out, ro.zoom, error)) {
      ips::print_fatal(kProgram, error);
      return 1;
    }
  } else if (!ips::write_text_file(ro.out, svg, error)) {
    ips::print_fatal(kProgram, error);
    return 1;
  }
  std::set<std::string> tags;
  for (const auto& [key, track] : model.tracks()) tags.insert(track.tag);
  const size_t channels = model.pose_channels().size();
  std::fprintf(stderr, "%s: wrote %s: %s, %zu estimates of %zu tag%s on %zu channel%s, %s\n",
               kProgram, ro.out.c_str(),
               model.has_site() ? ("site " + ips::printable(model.site_name())).c_str()
                                : "no site",
               model.tracks().size(), tags.size(), tags.size() == 1 ? "" : "s", channels,
               channels == 1 ? "" : "s", when.c_str());
  if (feed.stats().messages == 0)
    std::fprintf(stderr, "%s: warning: no message was read: the map is empty\n", kProgram);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"ips-view: a web page for the bus or for a log, seen from any browser: the floor "
               "map with anchors, every tag's estimates with covariance ellipses and trails, "
               "ground truth, a channel table and each process's health, updated live. "
               "`ips-view render` draws the map to SVG or PNG for reports.",
               kProgram};
  ips::CommonOptions opts;
  ips::add_common_options(app, opts);
  ServeOptions so;
  MapOptions mo;
  app.add_option("LOG", so.log, "serve this LCM log, played at --speed, instead of the live bus");
  app.add_option("--bind", so.bind,
                 "address to serve on (0.0.0.0: every interface; there is no login)")
      ->capture_default_str();
  app.add_option("--port", so.port, "TCP port (0: any free one, printed)")
      ->check(CLI::Range(0, 65535))
      ->capture_default_str();
  app.add_option("--speed", so.speed, "with LOG: playback speed (0: the whole log at once)")
      ->check(CLI::Range(0.0, 1000.0))
      ->capture_default_str();
  app.add_option("--update-hz", so.update_hz, "live updates sent to each page per second")
      ->check(CLI::Range(0.2, 30.0))
      ->capture_default_str();
  app.add_option("--max-clients", so.max_clients,
                 "HTTP connections at once (pages and requests; when all are taken, a new one "
                 "evicts an idle or unfinished one)")
      ->check(CLI::Range(1, 1024))
      ->capture_default_str();
  app.add_option("--max-clients-per-peer", so.max_clients_per_peer,
                 "HTTP connections at once from one address (0: --max-clients)")
      ->check(CLI::Range(0, 1024))
      ->capture_default_str();
  app.add_option("--header-timeout", so.header_timeout_s,
                 "seconds from a connection's accept to a whole request head (else 408)")
      ->check(CLI::Range(0.1, 60.0))
      ->capture_default_str();

  RenderOptions ro;
  CLI::App* render_cmd = app.add_subcommand(
      "render", "draw the floor map of a log (at its end, or --at S) or of the live bus "
                "(--live S) to an SVG or PNG file");
  render_cmd->add_option("LOG", ro.log, "LCM log to draw");
  render_cmd->add_option("--out", ro.out, "output file, .svg or .png (PNG needs rsvg-convert)")
      ->required();
  render_cmd->add_option("--at", ro.at_s, "draw the state S seconds after the log's first event")
      ->check(CLI::NonNegativeNumber);
  render_cmd->add_option("--live", ro.live_s, "listen to the bus for S seconds, then draw")
      ->check(CLI::PositiveNumber);
  render_cmd->add_option("--wait-site", ro.wait_site_s,
                         "with --live: when no SITE message has come after --live S, listen on "
                         "until one does, at most this many seconds more (none by then: an "
                         "error, nothing written)")
      ->check(CLI::Range(0.0, 3600.0));
  render_cmd->add_option("--min-tracks", ro.min_tracks,
                         "with --wait-site: also listen on (within the same bound) until this "
                         "many tracks, a tag on one channel each, are on the map (fewer by then: "
                         "an error, nothing written)")
      ->check(CLI::Range(0, 100000));
  render_cmd->add_option("--zoom", ro.zoom, "PNG: scale factor")->check(CLI::Range(0.1, 20.0))
      ->capture_default_str();
  render_cmd->add_flag("--force", ro.force, "overwrite --out when it exists");
  render_cmd->add_option("--floor", ro.floor,
                         "draw this floor of the site: its plan, its zones and the tracks on it "
                         "(default: the lowest floor's plan, everything)")
      ->check(CLI::Range(-20, 500));
  for (CLI::App* a : {&app, render_cmd}) {
    a->add_option("--width", mo.width_px, "map size limit, pixels")
        ->check(CLI::Range(100.0, 20000.0))
        ->capture_default_str();
    a->add_option("--height", mo.height_px, "map size limit, pixels")
        ->check(CLI::Range(100.0, 20000.0))
        ->capture_default_str();
    a->add_option("--sigma", mo.sigma, "covariance ellipses at this many sigmas (0: none)")
        ->check(CLI::Range(0.0, 10.0))
        ->capture_default_str();
    a->add_flag("--no-trails", mo.no_trails, "draw no trails");
    a->add_option("--title", mo.title, "the map's title (default: ips-view and the site's name)");
  }
  render_cmd->fallthrough();
  int rc = 0;
  if (!ips::parse_command_line(app, opts, argc, argv, rc)) return rc;
  if (*render_cmd) return ips::run_reporting_errors(kProgram, [&] { return render(opts, ro, mo); });
  return ips::run_reporting_errors(kProgram, [&] { return serve(opts, so, mo); });
}
