#pragma once
// What makes ips-site read its file again, inside the node's loop: a change in the file's
// directory (inotify), and SIGHUP.
#include <chrono>
#include <functional>
#include <string>

#include "core/node.hpp"

namespace ips::site_tool {

// Watches the directory that holds `path` (inotify), so that a file replaced by a rename, as
// editors and configuration tools save, is seen as well as one written in place. Events for the
// file's name are settled: `on_change` runs `settle_s` after the last of a burst (at most
// kMaxSettleS after its first), so a save made of several steps (create, write, close; or the
// old file renamed away, then the new one written) is read once, complete. A change to the file
// behind a symlink is not a change in this directory: only SIGHUP sees it.
class FileWatch {
 public:
  static constexpr double kMaxSettleS = 1.0;
  // `on_lost(why)`: the watch ended (the directory was removed or renamed, or the kernel refused
  // it at start); only SIGHUP re-reads from then on.
  FileWatch(Node& node, const std::string& path, double settle_s, std::function<void()> on_change,
            std::function<void(const std::string& why)> on_lost);
  ~FileWatch();
  FileWatch(const FileWatch&) = delete;
  FileWatch& operator=(const FileWatch&) = delete;

  const std::string& directory() const { return dir_; }
  bool watching() const { return wd_ >= 0; }

 private:
  void on_events();
  void arm();
  void lost(const std::string& why);

  Node& node_;
  std::string dir_;
  std::string name_;
  double settle_s_;
  std::function<void()> on_change_;
  std::function<void(const std::string&)> on_lost_;
  int inotify_fd_ = -1;
  int wd_ = -1;
  int timer_fd_ = -1;
  bool armed_ = false;
  std::chrono::steady_clock::time_point burst_start_;
};

// SIGHUP calls `on_hangup` in the node's loop instead of stopping the process: for a daemon it
// means "read your configuration again" (systemctl kill -s HUP). The node stops on SIGINT and
// SIGTERM as before. One at a time in a process.
class HangupHandler {
 public:
  HangupHandler(Node& node, std::function<void()> on_hangup);
  ~HangupHandler();
  HangupHandler(const HangupHandler&) = delete;
  HangupHandler& operator=(const HangupHandler&) = delete;

 private:
  Node& node_;
  int read_fd_ = -1;
};

}  // namespace ips::site_tool
