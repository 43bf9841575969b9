#pragma once
// ips-mqtt's connection to the MQTT broker (libmosquitto). The network runs in the link's own
// thread: it connects, reconnects after a loss with an exponential back-off (min, 2 min, 4 min, ...
// capped at max), and writes what publish() queued. publish() never waits for the broker: it
// queues the message when connected and returns at once; when not connected (or too much is
// still unsent) it refuses, and the caller counts the message as not sent.
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

struct mosquitto;

namespace ips::mqtt {

struct BrokerOptions {
  std::string host = "127.0.0.1";
  int port = 1883;
  std::string client_id;  // empty: "ips-mqtt-<host>-<pid>"
  int keepalive_s = 30;
  std::string username;
  std::string password;  // from --password-file or IPS_MQTT_PASSWORD, never the command line
  std::string cafile;    // TLS when set
  std::string certfile;
  std::string keyfile;
  bool tls_insecure = false;
  int qos = 0;
  double reconnect_min_s = 1;
  double reconnect_max_s = 30;
  // Messages queued but not yet written (QoS 0) or acknowledged (QoS 1) beyond which publish()
  // refuses: a broker that reads too slowly costs messages, not memory.
  int max_queued = 10000;
};

class BrokerLink {
 public:
  // Sets the client up (credentials, TLS files); throws std::runtime_error with one line when
  // libmosquitto refuses them. Nothing is connected before start().
  explicit BrokerLink(BrokerOptions opts);
  ~BrokerLink();
  BrokerLink(const BrokerLink&) = delete;
  BrokerLink& operator=(const BrokerLink&) = delete;

  // Starts the network thread (first connection attempt at once).
  void start();

  enum class Sent { kQueued, kNotConnected, kQueueFull, kRefused };
  // Queues a message for the broker; never blocks on the network.
  Sent publish(const std::string& topic, const std::string& payload, bool retain);

  bool connected() const { return connected_.load(); }
  // "127.0.0.1:1883"
  std::string address() const;

  // What the network thread saw since the last call: connections made and lost, in order.
  struct Event {
    bool connected;
    std::string reason;  // why a connection failed or ended ("" on a clean connection)
    std::chrono::system_clock::time_point at;
  };
  std::vector<Event> take_events();

  // Messages handed to libmosquitto and not yet written/acknowledged on this connection.
  int64_t queued() const { return queued_.load(); }

 private:
  void run();
  void push_event(bool connected, std::string reason);
  void wait_before_retry(double seconds);
  static void on_connect(struct mosquitto*, void* self, int rc);
  static void on_disconnect(struct mosquitto*, void* self, int rc);
  static void on_publish(struct mosquitto*, void* self, int mid);

  BrokerOptions opts_;
  struct mosquitto* mosq_ = nullptr;
  std::thread thread_;
  std::atomic<bool> stopping_{false};
  std::atomic<bool> connected_{false};
  std::atomic<int64_t> queued_{0};
  std::mutex mutex_;  // events_ and the stop wake-up
  std::condition_variable wake_;
  std::vector<Event> events_;
  std::string connack_reason_;  // the broker's refusal, seen in on_connect (network thread only)
};

}  // namespace ips::mqtt
