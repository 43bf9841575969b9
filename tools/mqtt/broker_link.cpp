#include "tools/mqtt/broker_link.hpp"

#include <mosquitto.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <stdexcept>

namespace ips::mqtt {

namespace {

std::string describe(int rc, int saved_errno) {
  std::string text = rc == MOSQ_ERR_ERRNO ? std::strerror(saved_errno) : mosquitto_strerror(rc);
  if (!text.empty() && text.back() == '.') text.pop_back();  // "The connection was lost."
  return text;
}

struct LibInit {
  LibInit() { mosquitto_lib_init(); }
  ~LibInit() { mosquitto_lib_cleanup(); }
};

}  // namespace

BrokerLink::BrokerLink(BrokerOptions opts) : opts_(std::move(opts)) {
  static LibInit lib;
  if (opts_.client_id.empty()) {
    char host[256] = {};
    gethostname(host, sizeof host - 1);
    opts_.client_id = "ips-mqtt-" + std::string(host) + "-" + std::to_string(getpid());
  }
  // A clean session: the broker keeps nothing of ours between connections (we keep no queue
  // across an outage either: docs/mqtt.md#reconnect).
  mosq_ = mosquitto_new(opts_.client_id.c_str(), true, this);
  if (!mosq_) throw std::runtime_error("libmosquitto: cannot create a client");
  mosquitto_threaded_set(mosq_, true);  // publish() only queues; the link's thread writes
  mosquitto_int_option(mosq_, MOSQ_OPT_PROTOCOL_VERSION, MQTT_PROTOCOL_V311);
  mosquitto_connect_callback_set(mosq_, &BrokerLink::on_connect);
  mosquitto_disconnect_callback_set(mosq_, &BrokerLink::on_disconnect);
  mosquitto_publish_callback_set(mosq_, &BrokerLink::on_publish);
  int rc = MOSQ_ERR_SUCCESS;
  if (!opts_.username.empty() &&
      (rc = mosquitto_username_pw_set(mosq_, opts_.username.c_str(),
                                      opts_.password.empty() ? nullptr : opts_.password.c_str())))
    throw std::runtime_error(std::string("--username: ") + mosquitto_strerror(rc));
  if (!opts_.cafile.empty()) {
    rc = mosquitto_tls_set(mosq_, opts_.cafile.c_str(), nullptr,
                           opts_.certfile.empty() ? nullptr : opts_.certfile.c_str(),
                           opts_.keyfile.empty() ? nullptr : opts_.keyfile.c_str(), nullptr);
    if (rc)
      throw std::runtime_error(std::string("TLS files (--cafile, --cert, --key): ") +
                               mosquitto_strerror(rc));
    if (opts_.tls_insecure) mosquitto_tls_insecure_set(mosq_, true);
  }
}

BrokerLink::~BrokerLink() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
  mosquitto_destroy(mosq_);
}

void BrokerLink::start() {
  thread_ = std::thread([this] { run(); });
}

std::string BrokerLink::address() const {
  const bool v6 = opts_.host.find(':') != std::string::npos;
  return (v6 ? "[" + opts_.host + "]" : opts_.host) + ":" + std::to_string(opts_.port);
}

BrokerLink::Sent BrokerLink::publish(const std::string& topic, const std::string& payload,
                                     bool retain) {
  if (!connected_) return Sent::kNotConnected;
  if (queued_.load() >= opts_.max_queued) return Sent::kQueueFull;
  if (payload.size() > static_cast<size_t>(INT32_MAX)) return Sent::kRefused;
  queued_.fetch_add(1);
  const int rc = mosquitto_publish(mosq_, nullptr, topic.c_str(), static_cast<int>(payload.size()),
                                   payload.data(), opts_.qos, retain);
  if (rc == MOSQ_ERR_SUCCESS) return Sent::kQueued;
  queued_.fetch_sub(1);
  return rc == MOSQ_ERR_NO_CONN || rc == MOSQ_ERR_CONN_LOST ? Sent::kNotConnected : Sent::kRefused;
}

std::vector<BrokerLink::Event> BrokerLink::take_events() {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<Event> out;
  out.swap(events_);
  return out;
}

void BrokerLink::push_event(bool connected, std::string reason) {
  std::lock_guard<std::mutex> lock(mutex_);
  events_.push_back({connected, std::move(reason), std::chrono::system_clock::now()});
}

void BrokerLink::wait_before_retry(double seconds) {
  std::unique_lock<std::mutex> lock(mutex_);
  wake_.wait_for(lock, std::chrono::duration<double>(seconds), [this] { return stopping_.load(); });
}

// The network thread. Not mosquitto_loop_start(): its loop ends for good on a DNS or TLS error,
// and its back-off grows as min*(n+1)^2; here every failure is retried, and the delay doubles.
void BrokerLink::run() {
  double delay_s = opts_.reconnect_min_s;
  // A connection attempt that neither succeeds nor fails (a host that drops SYNs) is given up
  // after this long and tried again.
  const auto attempt_timeout = std::chrono::seconds(std::max(10, opts_.keepalive_s));
  while (!stopping_) {
    connack_reason_.clear();
    int rc = mosquitto_connect_async(mosq_, opts_.host.c_str(), opts_.port, opts_.keepalive_s);
    int saved_errno = errno;
    bool was_connected = false;
    const auto attempt_start = std::chrono::steady_clock::now();
    if (rc == MOSQ_ERR_SUCCESS) {
      while (!stopping_) {
        rc = mosquitto_loop(mosq_, 200, 1);
        saved_errno = errno;
        if (rc != MOSQ_ERR_SUCCESS) break;
        was_connected = was_connected || connected_;
        if (!connected_ && std::chrono::steady_clock::now() - attempt_start > attempt_timeout) {
          rc = MOSQ_ERR_ERRNO;
          saved_errno = ETIMEDOUT;
          break;
        }
      }
    }
    if (stopping_) break;
    connected_ = false;
    std::string reason = !connack_reason_.empty() ? connack_reason_ : describe(rc, saved_errno);
    push_event(false, reason);
    if (was_connected) delay_s = opts_.reconnect_min_s;
    wait_before_retry(delay_s);
    delay_s = std::min(delay_s * 2, opts_.reconnect_max_s);
  }
  if (connected_) {
    // What publish() accepted goes out before we leave (at most 2 s).
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(2);
    while (queued_.load() > 0 && std::chrono::steady_clock::now() < deadline &&
           mosquitto_loop(mosq_, 100, 1) == MOSQ_ERR_SUCCESS) {
    }
    mosquitto_disconnect(mosq_);
    mosquitto_loop(mosq_, 100, 1);
    connected_ = false;
  }
}

void BrokerLink::on_connect(struct mosquitto*, void* self, int rc) {
  auto* link = static_cast<BrokerLink*>(self);
  if (rc != 0) {
    link->connack_reason_ =
        std::string("the broker refused the connection: ") + mosquitto_connack_string(rc);
    if (link->connack_reason_.back() == '.') link->connack_reason_.pop_back();
    return;
  }
  link->queued_ = 0;
  link->connected_ = true;
  link->push_event(true, "");
}

void BrokerLink::on_disconnect(struct mosquitto*, void* self, int) {
  static_cast<BrokerLink*>(self)->connected_ = false;
}

void BrokerLink::on_publish(struct mosquitto*, void* self, int) {
  // Messages of an earlier connection resent after a reconnect (QoS 1) were not counted in this
  // connection's queue: never below 0.
  auto& queued = static_cast<BrokerLink*>(self)->queued_;
  int64_t n = queued.load();
  while (n > 0 && !queued.compare_exchange_weak(n, n - 1)) {
  }
}

}  // namespace ips::mqtt
