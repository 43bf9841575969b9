#include "viewer-headless/png_output.hpp"

#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <vector>

extern char** environ;

namespace ips::view {

namespace {

// Removes the temporary file however the function returns.
struct TempFile {
  std::string path;
  int fd = -1;
  ~TempFile() {
    if (fd >= 0) ::close(fd);
    if (!path.empty()) ::unlink(path.c_str());
  }
};

bool write_all(int fd, const std::string& bytes) {
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    done += static_cast<size_t>(n);
  }
  return true;
}

}  // namespace

bool svg_to_png(const std::string& svg, const std::string& out_path, double zoom,
                std::string& error) {
  if (!(zoom > 0) || zoom > 20) {
    error = "zoom must be in (0, 20]";
    return false;
  }
  const std::filesystem::path dir = std::filesystem::temp_directory_path();
  std::string pattern = (dir / "ips-view-XXXXXX.svg").string();
  TempFile tmp;
  tmp.fd = ::mkstemps(pattern.data(), 4);
  if (tmp.fd < 0) {
    error = "cannot create a temporary file in " + dir.string() + ": " + std::strerror(errno);
    return false;
  }
  tmp.path = pattern;
  if (!write_all(tmp.fd, svg)) {
    error = "cannot write " + tmp.path + ": " + std::strerror(errno);
    return false;
  }
  ::close(tmp.fd);
  tmp.fd = -1;

  char zoom_text[32];
  std::snprintf(zoom_text, sizeof zoom_text, "%g", zoom);
  std::vector<std::string> args = {"rsvg-convert", "--format",  "png",     "--background-color",
                                   "white",        "--zoom",    zoom_text, "--output",
                                   out_path,       tmp.path};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  const int rc = ::posix_spawnp(&pid, "rsvg-convert", nullptr, nullptr, argv.data(), environ);
  if (rc != 0) {
    error = rc == ENOENT ? "PNG output needs rsvg-convert, which is not installed (Debian package "
                           "librsvg2-bin; scripts/install-deps installs it), or write .svg"
                         : std::string("cannot run rsvg-convert: ") + std::strerror(rc);
    return false;
  }
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) {
      error = std::string("waitpid: ") + std::strerror(errno);
      return false;
    }
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    error = "rsvg-convert failed (" +
            (WIFEXITED(status) ? "status " + std::to_string(WEXITSTATUS(status))
                               : "signal " + std::to_string(WTERMSIG(status))) +
            ") writing " + out_path;
    return false;
  }
  return true;
}

}  // namespace ips::view
