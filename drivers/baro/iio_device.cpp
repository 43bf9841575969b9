#include "drivers/baro/iio_device.hpp"

#include <dirent.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cstdlib>
#include <cstring>
#include <memory>

#include "core/text_escape.hpp"
#include "drivers/baro/sysfs_value.hpp"

namespace ips::baro {

namespace {

// A sysfs attribute holds at most a page; ours hold a number.
constexpr size_t kMaxAttributeBytes = 256;

// Reads a small attribute file: open, pread at offset 0, close. 0, or the errno (EFBIG: longer
// than kMaxAttributeBytes).
int read_attribute(const std::string& path, std::string& text) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return errno;
  char buf[kMaxAttributeBytes + 1];
  ssize_t n;
  do {
    n = ::pread(fd, buf, sizeof buf, 0);
  } while (n < 0 && errno == EINTR);
  const int err = n < 0 ? errno : 0;
  ::close(fd);
  if (err != 0) return err;
  if (static_cast<size_t>(n) > kMaxAttributeBytes) return EFBIG;
  text.assign(buf, static_cast<size_t>(n));
  return 0;
}

std::string read_error_text(int err) {
  return err == EFBIG ? "longer than " + std::to_string(kMaxAttributeBytes) + " bytes"
                      : std::string(std::strerror(err));
}

// The device went away: its directory or attribute is gone, or the kernel removed the device.
bool gone_errno(int err) {
  return err == ENOENT || err == ENODEV || err == ENXIO || err == ENOTDIR;
}

std::string trimmed(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == '\r' || s.back() == ' ')) s.pop_back();
  return s;
}

// "iio:device12" -> 12; -1 for any other entry (triggers, buffers, dot entries).
long device_number(const char* entry) {
  constexpr std::string_view kPrefix = "iio:device";
  const std::string_view e(entry);
  if (e.size() <= kPrefix.size() || e.size() > kPrefix.size() + 6 ||
      e.substr(0, kPrefix.size()) != kPrefix)
    return -1;
  long n = 0;
  for (char c : e.substr(kPrefix.size())) {
    if (c < '0' || c > '9') return -1;
    n = n * 10 + (c - '0');
  }
  return n;
}

std::string quoted_name(const std::string& name) { return "'" + printable(name) + "'"; }

}  // namespace

bool list_iio_devices(const std::string& root, std::vector<IioDeviceEntry>& out,
                      std::string& error) {
  out.clear();
  std::unique_ptr<DIR, int (*)(DIR*)> dir(opendir(root.c_str()), &closedir);
  if (!dir) {
    error = "cannot read " + printable(root) + ": " + std::strerror(errno);
    return false;
  }
  std::vector<std::pair<long, IioDeviceEntry>> found;
  while (const dirent* e = readdir(dir.get())) {
    const long n = device_number(e->d_name);
    if (n < 0) continue;
    IioDeviceEntry entry;
    entry.dir = root + "/" + e->d_name;
    if (read_attribute(entry.dir + "/name", entry.name) == 0) entry.name = trimmed(entry.name);
    found.emplace_back(n, std::move(entry));
  }
  std::sort(found.begin(), found.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });
  for (auto& f : found) out.push_back(std::move(f.second));
  return true;
}

IioLookup find_iio_device_by_name(const std::string& root, const std::string& name) {
  IioLookup r;
  std::vector<IioDeviceEntry> all;
  if (!list_iio_devices(root, all, r.reason)) {
    r.reason += " (is the sensor's kernel driver loaded?)";
    return r;
  }
  std::vector<std::string> matches;
  std::string names;
  for (const auto& d : all) {
    if (d.name == name) matches.push_back(d.dir);
    names += (names.empty() ? "" : ", ") + printable(d.dir.substr(root.size() + 1)) + " " +
             quoted_name(d.name);
  }
  if (matches.size() == 1) {
    r.kind = IioLookup::Kind::kFound;
    r.dir = matches[0];
    return r;
  }
  if (matches.empty()) {
    r.reason = "no IIO device named " + quoted_name(name) + " in " + printable(root) + " (" +
               (names.empty() ? "there are none" : "found: " + names) + ")";
    return r;
  }
  r.kind = IioLookup::Kind::kAmbiguous;
  std::string dirs;
  for (const auto& d : matches) dirs += (dirs.empty() ? "" : ", ") + printable(d);
  r.reason = std::to_string(matches.size()) + " IIO devices are named " + quoted_name(name) + " (" +
             dirs + "): pick one by its path";
  return r;
}

IioDevice::OpenStatus IioDevice::open(const std::string& dir, std::string& error) {
  open_ = false;
  struct stat st {};
  if (stat(dir.c_str(), &st) != 0) {
    error = printable(dir) + ": " + std::strerror(errno);
    return OpenStatus::kMissing;
  }
  if (!S_ISDIR(st.st_mode)) {
    error = printable(dir) + ": not a directory";
    return OpenStatus::kMissing;
  }
  dir_ = dir;
  char real[PATH_MAX];
  real_dir_ = realpath(dir.c_str(), real) ? real : dir;
  name_.clear();
  if (read_attribute(dir_ + "/name", name_) == 0) name_ = trimmed(name_);
  for (Channel* c : {&pressure_, &temperature_, &humidity_}) find_channel(*c);
  if (!pressure_.present) {
    error = printable(dir) + " (" + quoted_name(name_) +
            ") has no in_pressure_input, nor in_pressure_raw with in_pressure_scale: not a "
            "barometer";
    return OpenStatus::kNotBarometer;
  }
  open_ = true;
  return OpenStatus::kOpen;
}

bool IioDevice::exists(const std::string& attribute) const {
  return access((dir_ + "/" + attribute).c_str(), F_OK) == 0;
}

void IioDevice::find_channel(Channel& c) const {
  const std::string p = c.prefix;
  c.present = c.raw = c.offset = false;
  if (exists(p + "_input")) {
    c.present = true;
  } else if (exists(p + "_raw") && exists(p + "_scale")) {
    c.present = c.raw = true;
    c.offset = exists(p + "_offset");
  }
}

IioDevice::ReadStatus IioDevice::read_channel(const Channel& c, double& value,
                                              std::string& reason) const {
  std::string input, raw, scale, offset;
  IioChannelText text{c.prefix, std::nullopt, std::nullopt, std::nullopt, std::nullopt};
  auto get = [&](const char* suffix, std::string& storage, std::optional<std::string_view>& slot) {
    const std::string attribute = std::string(c.prefix) + suffix;
    const int err = read_attribute(dir_ + "/" + attribute, storage);
    if (err != 0) {
      reason = attribute + ": " + read_error_text(err);
      return gone_errno(err) ? ReadStatus::kGone : ReadStatus::kBad;
    }
    slot = storage;
    return ReadStatus::kOk;
  };
  ReadStatus s = ReadStatus::kOk;
  if (!c.raw) {
    s = get("_input", input, text.input);
  } else {
    s = get("_raw", raw, text.raw);
    if (s == ReadStatus::kOk) s = get("_scale", scale, text.scale);
    if (s == ReadStatus::kOk && c.offset) s = get("_offset", offset, text.offset);
  }
  if (s != ReadStatus::kOk) return s;
  double v = 0;
  if (!iio_channel_value(text, v, reason)) return ReadStatus::kBad;
  // Division for the milli units: 21430 / 1000 is exactly the double nearest 21.43.
  value = c.milli ? v / 1000.0 : v * 1000.0;
  return ReadStatus::kOk;
}

IioDevice::ReadStatus IioDevice::read(BaroReading& out, std::string& reason) const {
  if (!open_) {
    reason = "not open";
    return ReadStatus::kGone;
  }
  BaroReading r;
  ReadStatus s = read_channel(pressure_, r.pressure_pa, reason);
  if (s == ReadStatus::kOk && temperature_.present)
    s = read_channel(temperature_, r.temperature_c, reason);
  if (s == ReadStatus::kOk && humidity_.present)
    s = read_channel(humidity_, r.humidity_pct, reason);
  if (s == ReadStatus::kOk) out = r;
  return s;
}

bool IioDevice::set_pressure_oversampling(int ratio, std::string& error) const {
  const std::string attribute = "in_pressure_oversampling_ratio";
  const int fd = ::open((dir_ + "/" + attribute).c_str(), O_WRONLY | O_TRUNC | O_CLOEXEC);
  if (fd < 0) {
    const int err = errno;
    error = err == ENOENT ? printable(dir_) + " has no " + attribute + ": the kernel driver of " +
                                quoted_name(name_) + " cannot set pressure oversampling"
                          : attribute + ": " + std::strerror(err);
    return false;
  }
  const std::string text = std::to_string(ratio) + "\n";
  ssize_t n;
  do {
    n = ::write(fd, text.data(), text.size());
  } while (n < 0 && errno == EINTR);
  const int err = n < 0 ? errno : 0;
  ::close(fd);
  if (n == static_cast<ssize_t>(text.size())) return true;
  if (err == EINVAL) {
    std::string available;
    if (read_attribute(dir_ + "/" + attribute + "_available", available) == 0)
      available = " (available: " + printable(trimmed(available)) + ")";
    error = "the kernel refused " + attribute + " " + std::to_string(ratio) + available;
  } else {
    error = attribute + ": " + (err != 0 ? std::strerror(err) : "short write");
  }
  return false;
}

}  // namespace ips::baro
