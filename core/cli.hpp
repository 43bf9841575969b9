#pragma once
// The command line every program shares: --lcm-url, --site, --channel KIND=NAME, --log-level,
// --help, --version (CLI11). The same flag means the same thing in every program.
#include <CLI/CLI.hpp>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "core/lcm_url.hpp"

namespace ips {

// Messages liblcm may hold for one subscription while the process is busy (its own default, 30,
// is a fraction of a second of a lab's traffic and dropped the rest without a word).
inline constexpr int kDefaultLcmQueue = 20000;

struct CommonOptions {
  std::string lcm_url;    // empty: LCM's default or LCM_DEFAULT_URL
  std::string site_path;  // empty: wait for the first SITE message
  std::string log_level = "info";
  std::vector<std::string> channel_overrides;  // KIND=NAME
  // Messages liblcm may hold per subscription while the process is busy (--lcm-queue; 0: no
  // limit) and the kernel receive buffer asked for when the URL does not say (--lcm-recv-buf).
  // docs/networking.md#loss
  int lcm_queue = kDefaultLcmQueue;
  int lcm_recv_buf = kDefaultRecvBufBytes;
  // Who reads a udpm bus (--lcm-receiver): "liblcm" (its receive thread and queues), "direct"
  // (the process's own loop reads the socket: core/lcm_udpm_receiver.hpp) or "auto" (direct
  // when the kernel grants the receive buffer asked for, at least 4 MiB, else liblcm). A
  // program may set its own default before add_common_options() (ips-fuse: auto); other URLs
  // are always liblcm's.
  std::string lcm_receiver = "liblcm";
  // After each message, how long the loop polls the bus without sleeping (--busy-poll-us; 0:
  // it sleeps at once). Only with the direct receiver (liblcm's receive thread sleeps anyway).
  int busy_poll_us = 0;
  // The tags this instance handles (--tags: ids and globs, comma-separated; --shard K/N), for
  // programs that offer them (CommonFlags::tags; core/tag_selector.hpp). Empty: every tag.
  std::string tags;
  std::string shard;

  // The channel to use for a kind (e.g. "UWB_RANGE"), after --channel overrides.
  std::string channel(const std::string& kind) const;
};

// Which of the common options a program offers.
struct CommonFlags {
  bool lcm = true;
  bool site = true;
  bool channels = true;
  bool tags = false;  // --tags and --shard: a subset of the tags (core/tag_filter.hpp)
};

void add_common_options(CLI::App& app, CommonOptions& opts, CommonFlags flags = {});

// Parses argv; on --help prints it and returns 0 in `exit_code` (likewise --version: one line,
// "<program> 0.1.0 (git <describe>, <build type>)", core/version.hpp); on an error prints one line
// "<program>: error: <what>" and returns 2 in `exit_code`. Returns true when the program should
// go on. Also applies --log-level and checks --channel syntax.
bool parse_command_line(CLI::App& app, const CommonOptions& opts, int argc, char** argv,
                        int& exit_code);
// (--channel KIND must be one of channel::kAllKinds: a misspelt kind is an error, not ignored;
// --tags and --shard are checked the same way.)

// Prints "<program>: error: <what>" on stderr (one line, for start-up failures).
void print_fatal(const std::string& program, const std::string& what);

// Runs a program's body. A configuration error escaping it (ConfigError: bad site or scenario
// file) ends the program with one error line and status 2; an LCM URL that cannot be opened
// (LcmOpenError) with one line and status 1.
int run_reporting_errors(const std::string& program, const std::function<int()>& body);

}  // namespace ips
