#pragma once
// The node runtime every process is built on: owns the LCM instance, offers typed subscribe and
// publish with message counters, runs one poll loop over the LCM fd, timers and signals, ends
// cleanly (status 0) on SIGINT/SIGTERM/SIGHUP, and publishes health_t on HEALTH at 1 Hz.
#include <chrono>
#include <cstdint>
#include <functional>
#include <ips/health_t.hpp>
#include <lcm/lcm-cpp.hpp>
#include <poll.h>
#include <signal.h>

#include <list>
#include <map>
#include <memory>
#include <regex>
#include <set>
#include <stdexcept>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "core/cli.hpp"
#include "core/lcm_udpm_receiver.hpp"
#include "core/logging.hpp"
#include "core/seq_loss.hpp"
#include "core/socket_drops.hpp"
#include "core/time.hpp"

namespace ips {

struct NodeCounters {
  int64_t msgs_in = 0;
  int64_t msgs_out = 0;
  int64_t parse_errors = 0;
  int64_t drops = 0;
};

// What a process lost on the way in since it started (HEALTH carries it; docs/networking.md#loss).
struct BusLoss {
  int64_t kernel_drops = 0;   // datagrams the kernel dropped on our UDP sockets (buffer full)
  int64_t queue_drops = 0;    // messages liblcm's subscription queues dropped (as far as seen)
  SeqLossCounts seq;          // senders' sequence numbers (uwb_range_t, uwb_rx_t, ble_aoa_t)
  int32_t recv_buf_bytes = -1;       // the LCM receive socket's SO_RCVBUF as granted; -1 unknown
  int32_t recv_buf_requested = 0;    // what the URL asked for (0: the kernel's default)
  int lcm_queue = 0;                 // --lcm-queue (liblcm's receiver only)
  std::string receiver = "liblcm";   // --lcm-receiver: who read the bus ("liblcm" or "direct")
  // A JSON object of the above (ips-record's sidecar "loss").
  std::string json() const;
};

// Decodes an LCM message from bytes off the bus; false (never an exception) when the bytes are not
// a valid Msg. The generated decoders are hardened (lcmtypes/harden_generated.cmake); the catch is
// the last line of defence against allocation failure.
template <class Msg>
bool decode_message(Msg& msg, const void* data, size_t size) {
  if (size > INT32_MAX) return false;
  try {
    return msg.decode(data, 0, static_cast<int>(size)) >= 0;
  } catch (const std::exception&) {
    return false;
  }
}

// The default of --lcm-queue (core/cli.hpp).
inline constexpr int kSubscriptionQueueMessages = kDefaultLcmQueue;

class Node {
 public:
  // Opens LCM from opts.lcm_url; throws LcmOpenError (one clear line) when it cannot.
  Node(std::string name, const CommonOptions& opts);
  ~Node();
  Node(const Node&) = delete;
  Node& operator=(const Node&) = delete;

  const std::string& name() const { return name_; }
  // The host name HEALTH carries.
  const std::string& host() const { return host_; }
  const CommonOptions& options() const { return opts_; }
  lcm::LCM& lcm() { return *lcm_; }

  // Subscribes to `channel` with messages decoded as Msg. A message that does not decode as Msg
  // (wrong type or corrupt) is counted as a parse error and logged at a rate limit.
  template <class Msg>
  void subscribe(const std::string& channel,
                 std::function<void(const Msg&, const std::string& channel)> handler);

  // Publishes; a message liblcm refuses (e.g. too large) is counted as a drop and reported.
  template <class Msg>
  void publish(const std::string& channel, const Msg& msg) {
    std::vector<uint8_t>& buf = publish_buffer_;
    buf.resize(static_cast<size_t>(msg.getEncodedSize()));
    if (msg.encode(buf.data(), 0, static_cast<int>(buf.size())) < 0) {
      ++counters_.drops;
      report_error("channel " + channel + ": cannot encode " + Msg::getTypeName());
      return;
    }
    publish_raw(channel, buf.data(), buf.size());
  }
  void publish_raw(const std::string& channel, const void* data, size_t size);

  // Subscribes to `channel` (an LCM regex) with the undecoded bytes (a recorder, a bridge).
  using RawHandler = std::function<void(const lcm::ReceiveBuffer*, const std::string&)>;
  void subscribe_raw(const std::string& channel, RawHandler handler);

  // Calls `fn` every `period_s` seconds of monotonic time (first call one period from now).
  void add_timer(double period_s, std::function<void()> fn);

  // Watches a device's file descriptor (serial port, CAN or UDP/TCP socket, stdin) in the same
  // loop: `fn(revents)` runs when poll() reports `events` (or POLLERR/POLLHUP/POLLNVAL) on it.
  // Watching an fd again replaces its handler. The node does not own or close the fd; unwatch it
  // before closing it (a handler may unwatch its own fd).
  void watch_fd(int fd, short events, std::function<void(short revents)> fn);
  void unwatch_fd(int fd);

  // Runs the loop until SIGINT/SIGTERM/SIGHUP or stop(). Returns the process exit status: 0, or 1
  // when the LCM socket failed.
  int run();
  // Handles what is pending now, waiting at most `timeout_ms`; false once stopped.
  bool spin_once(int timeout_ms);
  void stop() { stopping_ = true; }
  bool stopping() const { return stopping_; }
  // The signal that stopped the loop (SIGINT, SIGTERM, SIGHUP), or 0.
  int stop_signal() const { return stop_signal_; }

  NodeCounters& counters() { return counters_; }
  // Reads the kernel's counters now and returns all loss figures.
  BusLoss loss();
  // True when this process reads its udpm bus itself (--lcm-receiver direct).
  bool direct_receiver() const { return direct_ != nullptr; }
  // Reports an error in health_t and logs it at a rate limit. A process in STATE_OK becomes
  // STATE_DEGRADED, and returns to STATE_OK once no error has been reported for
  // degraded_hold_s (last_error keeps the text). A state set with set_state() is kept as set.
  void report_error(const std::string& text);
  // last_error's text without a degradation: a condition that is over, said for the record
  // (ips-record resumed after a full disk: what the pause cost stays readable; the pause itself
  // was the error).
  void set_last_error(const std::string& text) { last_error_ = text; }
  // A condition that lasts, named by `key` (a device away: its path): the text becomes
  // last_error and is logged, and a process otherwise in STATE_OK is STATE_DEGRADED while any
  // such condition is on, however long, whatever set_state() says.
  void report_lasting_error(const std::string& key, const std::string& text);
  // The condition is over. Once none is left the process is back to its own state, and a
  // degradation by errors reported meanwhile ends too (they mostly came of the device going).
  void end_lasting_error(const std::string& key);
  // What a process in good health has to say, named by `key` (ips-ins: "T1: ... not a
  // foot-mounted IMU; no POSE_INS"): HEALTH's `note` (the notes joined by "; "), logged at info
  // when the key first appears (its text may change). Not a problem: the state is untouched.
  void report_note(const std::string& key, const std::string& text);
  void end_note(const std::string& key) { notes_.erase(key); }
  std::string note() const;
  void set_state(int8_t state) {
    state_ = state;
    degraded_by_error_ = false;
  }
  // What HEALTH says: the state, degraded while a lasting condition is on.
  int8_t state() const {
    return state_ == health_t::STATE_OK && !lasting_.empty() ? health_t::STATE_DEGRADED : state_;
  }
  // An estimator's innovation check for HEALTH's `consistency` (core/consistency.hpp).
  void set_consistency(std::string text) { consistency_ = std::move(text); }
  // How long a reported error keeps the process degraded (2 s: a transient fault shows in two
  // HEALTH reports, at least one however late they come, and a process is OK again soon after it
  // ends; docs/reliability.md).
  void set_degraded_hold(double seconds) { degraded_hold_s_ = seconds; }
  void publish_health();

 private:
  struct Timer {
    std::chrono::steady_clock::duration period;
    std::chrono::steady_clock::time_point next;
    std::function<void()> fn;
  };
  void dispatch_timers();
  void count_sequence(const lcm::ReceiveBuffer* rbuf);
  void measure_recv_buf();
  // --lcm-receiver direct: opens the socket and proves it hears the group (as liblcm's
  // self-test does); reads one batch and hands each message to the subscriptions that match.
  void open_direct_receiver(const std::string& url);
  // --lcm-receiver auto: keeps the direct receiver when its socket has the buffer asked for,
  // else closes it (liblcm's receiver then reads the bus).
  void choose_receiver(const std::string& url);
  bool read_direct();
  using DirectRoute = std::pair<const std::string, std::vector<RawHandler*>>;
  const DirectRoute& direct_route(std::string_view channel);
  // One per subscription: messages on its channels that reached us (a shadow subscription with
  // a longer queue sees them) against those liblcm handed to it; the difference is what its
  // queue dropped (liblcm 1.3 counts nothing itself).
  struct QueueWatch {
    int64_t seen = 0;
    int64_t delivered = 0;
  };

  std::string name_;
  CommonOptions opts_;
  std::unique_ptr<lcm::LCM> lcm_;
  std::list<RawHandler> handlers_;  // stable addresses: LCM keeps a pointer to each
  std::unique_ptr<LcmUdpmReceiver> direct_;
  struct DirectSubscription {
    std::regex channel;  // matched whole, as liblcm matches "^channel$"
    RawHandler* handler;
  };
  std::vector<DirectSubscription> direct_subscriptions_;
  // The handlers of each channel name heard (matched once; a new subscription clears it).
  struct NameHash {
    using is_transparent = void;
    size_t operator()(std::string_view s) const { return std::hash<std::string_view>{}(s); }
  };
  std::unordered_map<std::string, std::vector<RawHandler*>, NameHash, std::equal_to<>>
      direct_routes_;
  bool direct_routes_stale_ = false;
  std::vector<Timer> timers_;
  struct Watch {
    int fd;
    short events;
    std::function<void(short)> fn;
  };
  std::vector<Watch> watches_;
  std::vector<pollfd> pollfds_;
  NodeCounters counters_;
  std::list<QueueWatch> queue_watches_;
  KernelDropCounter kernel_drops_;
  SeqLossCounter seq_loss_;
  int64_t reported_bus_loss_ = 0;
  int32_t recv_buf_bytes_ = -1;
  int32_t recv_buf_requested_ = 0;
  int signal_fd_ = -1;
  int lcm_fd_ = -1;
  // --busy-poll-us, and when the last message came.
  std::chrono::steady_clock::duration busy_poll_{};
  std::chrono::steady_clock::time_point last_input_{};
  sigset_t old_sigmask_;
  std::vector<uint8_t> publish_buffer_;
  bool stopping_ = false;
  int stop_signal_ = 0;
  int8_t state_ = health_t::STATE_OK;
  std::string last_error_;
  std::string consistency_;
  bool degraded_by_error_ = false;  // state_ is DEGRADED because of report_error()
  bool degradation_published_ = true;  // a HEALTH has said so since the last report_error()
  std::set<std::string> lasting_;  // report_lasting_error() keys not ended yet
  std::map<std::string, std::string> notes_;  // report_note() by key
  std::chrono::steady_clock::time_point last_error_at_;
  double degraded_hold_s_ = 2.0;
  std::string health_channel_;
  std::string host_;
  std::chrono::steady_clock::time_point start_time_;
  bool failed_ = false;
  RateLimiter error_log_limit_;
};

template <class Msg>
void Node::subscribe(const std::string& channel,
                     std::function<void(const Msg&, const std::string& channel)> handler) {
  subscribe_raw(channel, [this, handler = std::move(handler)](const lcm::ReceiveBuffer* rbuf,
                                                              const std::string& chan) {
    Msg msg;
    if (!decode_message(msg, rbuf->data, static_cast<size_t>(rbuf->data_size))) {
      ++counters_.parse_errors;
      report_error("channel " + chan + ": message does not decode as " + Msg::getTypeName());
      return;
    }
    handler(msg, chan);
  });
}

}  // namespace ips
