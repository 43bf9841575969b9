// ips-uwb-tdoa-anchors: the reception reports of UWB TDoA anchors (SEWIO-style pipe-separated
// records, anchor_report_parser.hpp) from a TCP server, UDP datagrams or a file, published as
// uwb_rx_t on UWB_RX; and --to-records, which writes the UWB_RX messages of an LCM log as records.
// Record format, mapping and workflows: docs/hardware/uwb.md.
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <memory>
#include <set>

#include "core/channels.hpp"
#include "core/cli.hpp"
#include "core/log_input.hpp"
#include "core/log_to_lines.hpp"
#include "core/node.hpp"
#include "core/paced_input.hpp"
#include "core/udp_socket.hpp"
#include "core/text_escape.hpp"
#include "drivers/uwb_tdoa_anchors/anchor_report_parser.hpp"
#include "drivers/uwb_tdoa_anchors/record_splitter.hpp"
#include "drivers/uwb_tdoa_anchors/tcp_client.hpp"
#include "drivers/uwb_tdoa_anchors/wire_ids.hpp"

namespace {

constexpr const char* kProgram = "ips-uwb-tdoa-anchors";
using namespace ips::uwb_tdoa_anchors;

// A UDP datagram can hold at most 64 KiB; reports are far smaller.
constexpr size_t kMaxDatagramBytes = 65535;

// Every record read goes through here: parsed and published, or counted and reported.
class RecordPublisher {
 public:
  RecordPublisher(ips::Node& node, const WireIds& ids, PowerModel power, std::string source)
      : node_(node),
        ids_(ids),
        power_(power),
        channel_(node.options().channel(ips::channel::kUwbRx)),
        source_(std::move(source)) {}

  void on_record(std::string_view record, ips::utime_t utime) {
    ++node_.counters().msgs_in;
    ++records_;
    const AnchorReportParse p = parse_anchor_report(record);
    if (!p.ok) {
      bad(p.reason);
      return;
    }
    const AnchorReport& r = p.report;
    node_.publish(channel_, to_uwb_rx(r, utime, source_, ids_.name_for(r.anchor_id),
                                      ids_.name_for(r.sender_id), power_));
    ++published_;
  }
  void bad(const std::string& why) {
    ++node_.counters().parse_errors;
    ++bad_;
    if (first_bad_.empty()) first_bad_ = why;
    node_.report_error("skipped record: " + why);
  }
  // Records the splitter skipped as overlong since the last call.
  void check_overlong(const RecordSplitter& s) {
    for (; overlong_seen_ < s.overlong_records(); ++overlong_seen_)
      bad("record longer than " + std::to_string(kMaxRecordBytes) + " bytes");
  }
  void log_summary(const std::string& what) const {
    spdlog::info("{}: {}: {} records, {} published, {} bad{}", kProgram, what, records_, published_,
                 bad_, first_bad_.empty() ? "" : " (first: " + first_bad_ + ")");
  }
  int64_t records() const { return records_; }
  int64_t published() const { return published_; }
  const std::string& first_bad() const { return first_bad_; }

 private:
  ips::Node& node_;
  const WireIds& ids_;
  PowerModel power_;
  std::string channel_, source_;
  int64_t records_ = 0, published_ = 0, bad_ = 0, overlong_seen_ = 0;
  std::string first_bad_;
};

// --tcp: a client of the server that streams the anchors' records, reconnecting when it goes.
int read_tcp(ips::Node& node, const WireIds& ids, PowerModel power, const TcpClientOptions& o) {
  RecordPublisher pub(node, ids, power,
                      std::string(kProgram) + ":tcp:" + o.host + ":" + std::to_string(o.port));
  RecordSplitter splitter;
  TcpClient client(
      node, o,
      TcpClient::Callbacks{
          .on_connect = [&] { splitter.reset(); },
          .on_bytes =
              [&](std::string_view bytes, ips::utime_t utime) {
                splitter.feed(bytes, [&](std::string_view r) { pub.on_record(r, utime); });
                pub.check_overlong(splitter);
              },
          .on_disconnect =
              [&](const std::string&) {
                // A record without its line end at a disconnect may be cut: it is parsed (and
                // refused when incomplete), never silently forgotten.
                splitter.finish(
                    [&](std::string_view r) { pub.on_record(r, ips::wall_utime_now()); });
              },
      });
  spdlog::info("{}: connecting to {}", kProgram, client.endpoint());
  client.start();
  const int rc = node.run();
  pub.log_summary(client.endpoint() + " (" + std::to_string(client.connections()) +
                  " connections)");
  return rc;
}

// --udp: datagrams of one or more records each.
int read_udp(ips::Node& node, const WireIds& ids, PowerModel power, const std::string& addr,
             uint16_t port) {
  RecordPublisher pub(node, ids, power,
                      std::string(kProgram) + ":udp:" + addr + ":" + std::to_string(port));
  RecordSplitter splitter;
  ips::UdpSocket rx(
      node, kMaxDatagramBytes,
      ips::UdpSocket::Callbacks{
          .on_datagram =
              [&](std::string_view d, const std::string&, ips::utime_t utime) {
                splitter.feed_datagram(d, [&](std::string_view r) { pub.on_record(r, utime); });
                pub.check_overlong(splitter);
              },
          .on_dropped =
              [&](int64_t n) {
                node.counters().drops += n;
                node.report_error(std::to_string(n) + " datagram(s) dropped: receive queue full");
              },
          .on_truncated = [&](const std::string&) { pub.bad("datagram longer than 64 KiB"); },
      });
  std::string error;
  if (!rx.open(addr, port, error)) {
    ips::print_fatal(kProgram, "--udp: " + error);
    return 1;
  }
  spdlog::info("{}: receiving records on UDP {}:{}", kProgram, addr, rx.bound_port());
  const int rc = node.run();
  pub.log_summary("UDP " + addr + ":" + std::to_string(port));
  return rc;
}

// --file: a file of records (or stdin) to its end, handed on at `rate` records/s (0: as read):
// record k stamped k s, paced at speed `rate` (core/paced_input.hpp). While records wait for their
// turn the input is read at most 1024 records ahead, so a writer into a pipe waits too.
int read_file(ips::Node& node, const WireIds& ids, PowerModel power, int fd,
              const std::string& path, double rate) {
  const std::string name = path == "-" ? "stdin" : "'" + ips::printable(path) + "'";
  RecordPublisher pub(node, ids, power,
                      std::string(kProgram) + ":" + (path == "-" ? "stdin" : path));
  RecordSplitter splitter;
  int64_t handed_on = 0;
  ips::PacedInput<std::string> input(
      node, rate, 1024,
      [&](const std::string&) -> std::optional<ips::utime_t> { return handed_on * 1'000'000; },
      [&](const std::string& record) {
        ++handed_on;
        pub.on_record(record, ips::wall_utime_now());
      });
  auto take = [&](std::string_view r) { input.push(std::string(r)); };
  const int status = input.run(
      fd, kProgram, name,
      [&](std::string_view bytes) {
        splitter.feed(bytes, take);
        pub.check_overlong(splitter);
      },
      [&] { splitter.finish(take); });
  const bool eof = input.eof();
  pub.log_summary(name);
  if (status == 0 && eof && pub.records() > 0 && pub.published() == 0) {
    ips::print_fatal(kProgram, name + " holds no anchor report record (first: " +
                                   ips::printable(pub.first_bad()) + ")");
    return 1;
  }
  return status;
}

// --to-records: the UWB_RX messages of an LCM log as records on stdout. Ids that are not 4 hex
// digits and have no --id are given one (anchors 0001.., tags 1001..), reported on stderr as the
// --id options that read the records back under the log's names.
int to_records(const ips::CommonOptions& opts, WireIds ids, const std::string& path) {
  const std::string channel = opts.channel(ips::channel::kUwbRx);
  {
    auto in = ips::LogInput::open(kProgram, path);
    if (!in) return 1;
    std::set<std::string> anchors, tags;
    while (const ips::LogEvent* e = in->next()) {
      ips::uwb_rx_t m;
      if (e->channel != channel || !ips::decode_message(m, e->data, e->size)) continue;
      if (!valid_published_id(m.anchor_id) || !valid_published_id(m.sender_id)) continue;
      anchors.insert(m.anchor_id);
      (m.is_sync ? anchors : tags).insert(m.sender_id);
    }
    if (!in->finish("read what could be read")) return 1;
    std::string error;
    const std::vector<std::string> added = ids.assign_missing(anchors, tags, error);
    if (!error.empty()) {
      ips::print_fatal(kProgram, error);
      return 1;
    }
    if (!added.empty()) {
      std::string flags;
      for (const auto& a : added) flags += " --id " + a;
      spdlog::info("{}: ids that are not 4 hex digits got wire ids; read the records back with:{}",
                   kProgram, flags);
    }
  }
  return ips::write_log_as_lines<ips::uwb_rx_t>(
      kProgram, path, channel, "record", [&](const ips::uwb_rx_t& msg, std::string& line, std::string& why) {
        ips::uwb_rx_t m = msg;
        m.anchor_id = ids.wire_id_for(msg.anchor_id);
        m.sender_id = ids.wire_id_for(msg.sender_id);
        if (m.anchor_id.empty() || m.sender_id.empty()) {
          why = "id '" + (m.anchor_id.empty() ? msg.anchor_id : msg.sender_id) + "' has no wire id";
          return false;
        }
        const AnchorReportEncode enc = encode_anchor_report(m);
        if (!enc.ok) {
          why = enc.reason;
          return false;
        }
        line = enc.record;
        return true;
      });
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "ips-uwb-tdoa-anchors: reception reports of UWB TDoA anchors (SEWIO-style "
      "|anchor|E/A|sender|aa/bb|group|seq|5 counter bytes|...| records) from a TCP "
      "server, UDP datagrams or a file, published as uwb_rx_t on UWB_RX; --to-records "
      "writes an LCM log's UWB_RX messages as records. Format: docs/hardware/uwb.md.",
      kProgram};
  ips::CommonOptions opts;
  ips::add_common_options(app, opts, {.lcm = true, .site = false, .channels = true});
  std::string tcp, udp, file, to_records_log;
  std::vector<std::string> id_specs;
  double rate = 0, reconnect_max_s = 8.0;
  auto* o_tcp = app.add_option("--tcp", tcp,
                               "connect to the server streaming the records; reconnects when "
                               "it goes away")
                    ->type_name("HOST:PORT");
  auto* o_udp = app.add_option("--udp", udp,
                               "receive datagrams of records on this port (address default "
                               "127.0.0.1; 0.0.0.0 for every interface)")
                    ->type_name("[ADDR:]PORT");
  auto* o_file = app.add_option("--file", file, "read records from a file to its end ('-': stdin)")
                     ->type_name("PATH");
  auto* o_to = app.add_option("--to-records", to_records_log,
                              "write the UWB_RX messages of an LCM log as records on stdout, "
                              "then exit")
                   ->type_name("LOG.lcm");
  app.add_option("--id", id_specs,
                 "publish wire id HEX as NAME (e.g. --id 0006=A6, the site's anchor id); with "
                 "--to-records write NAME as HEX; repeatable")
      ->type_name("HEX=NAME");
  auto* o_rate = app.add_option("--rate", rate,
                                "--file: hand records on at this many per second (default: as "
                                "fast as they are read)")
                     ->check(CLI::Range(0.001, 1e6));
  auto* o_reconnect = app.add_option("--reconnect-max-s", reconnect_max_s,
                                     "--tcp: longest wait between connection attempts, s (the "
                                     "wait doubles from 0.25 s)")
                          ->capture_default_str()
                          ->check(CLI::Range(0.25, 3600.0));
  std::string power_name = "none";
  auto* o_power = app.add_option("--rx-power", power_name,
                                 "rx_power_dbm/fp_power_dbm from the 8 diagnostics read as the "
                                 "DW1000's (an inference; docs/hardware/uwb.md): none (NaN), "
                                 "dw1000-prf16 or dw1000-prf64")
                      ->capture_default_str()
                      ->check(CLI::IsMember({"none", "dw1000-prf16", "dw1000-prf64"}));
  int rc = 0;
  if (!ips::parse_command_line(app, opts, argc, argv, rc)) return rc;
  const PowerModel power = power_name == "dw1000-prf16"   ? PowerModel::kDw1000Prf16
                           : power_name == "dw1000-prf64" ? PowerModel::kDw1000Prf64
                                                          : PowerModel::kNone;

  auto usage_error = [](const std::string& what) {
    ips::print_fatal(kProgram, what + " (see --help)");
    return 2;
  };
  const int modes =
      (o_tcp->count() > 0) + (o_udp->count() > 0) + (o_file->count() > 0) + (o_to->count() > 0);
  if (modes != 1) return usage_error("give exactly one of --tcp, --udp, --file, --to-records");
  if (o_rate->count() > 0 && o_file->count() == 0) return usage_error("--rate goes with --file");
  if (o_power->count() > 0 && o_to->count() > 0)
    return usage_error("--rx-power does not go with --to-records");
  if (o_reconnect->count() > 0 && o_tcp->count() == 0)
    return usage_error("--reconnect-max-s goes with --tcp");
  WireIds ids;
  for (const std::string& spec : id_specs)
    if (const std::string why = ids.add(spec); !why.empty())
      return usage_error("--id " + ips::printable(spec) + ": " + why);

  if (o_to->count() > 0) return to_records(opts, ids, to_records_log);

  TcpClientOptions tcp_options;
  tcp_options.backoff_max_s = reconnect_max_s;
  std::string udp_addr;
  uint16_t udp_port = 0;
  if (o_tcp->count() > 0)
    if (const std::string why = parse_host_port(tcp, tcp_options.host, tcp_options.port);
        !why.empty())
      return usage_error("--tcp " + ips::printable(tcp) + ": " + why);
  if (o_udp->count() > 0)
    if (const std::string why = ips::parse_udp_bind(udp, udp_addr, udp_port); !why.empty())
      return usage_error("--udp " + ips::printable(udp) + ": " + why);
  // The file before LCM: without it there is nothing to wait for.
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> in(nullptr, &std::fclose);
  if (o_file->count() > 0 && file != "-") {
    in.reset(std::fopen(file.c_str(), "rb"));
    if (!in) {
      ips::print_fatal(kProgram,
                       "cannot read '" + ips::printable(file) + "': " + std::strerror(errno));
      return 1;
    }
  }
  return ips::run_reporting_errors(kProgram, [&] {
    ips::Node node(kProgram, opts);
    if (o_tcp->count() > 0) return read_tcp(node, ids, power, tcp_options);
    if (o_udp->count() > 0) return read_udp(node, ids, power, udp_addr, udp_port);
    return read_file(node, ids, power, in ? fileno(in.get()) : STDIN_FILENO, file, rate);
  });
}
