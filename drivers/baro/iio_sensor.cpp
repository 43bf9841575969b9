#include "drivers/baro/iio_sensor.hpp"

#include <cstdio>
#include <vector>

#include "core/text_escape.hpp"

namespace ips::baro {

namespace {

// ".../iio:deviceN" (the device itself) rather than a directory that holds one.
bool is_device_entry(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  return path.compare(slash == std::string::npos ? 0 : slash + 1, 10, "iio:device") == 0;
}

std::string seconds_text(double s) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", s);
  return buf;
}

}  // namespace

IioSensor::IioSensor(IioSensorConfig config) : config_(std::move(config)) {
  while (config_.path.size() > 1 && config_.path.back() == '/') config_.path.pop_back();
  if (!config_.path.empty() && config_.path.find('/') == std::string::npos)
    config_.path = config_.root + "/" + config_.path;
}

std::string IioSensor::selector() const {
  return config_.path.empty() ? "name '" + printable(config_.name) + "'"
                              : "path " + printable(config_.path);
}

bool IioSensor::open_device(std::string& error, bool& not_found) {
  not_found = false;
  std::string dir = config_.path;
  if (dir.empty()) {
    const IioLookup found = find_iio_device_by_name(config_.root, config_.name);
    if (found.kind != IioLookup::Kind::kFound) {
      not_found = found.kind == IioLookup::Kind::kNotFound;
      error = found.reason;
      return false;
    }
    dir = found.dir;
  } else if (!is_device_entry(dir)) {
    // A directory holding the device, e.g. the I2C device /sys/bus/i2c/devices/1-0077: its
    // address is stable where the device number is not.
    std::vector<IioDeviceEntry> inner;
    std::string ignored;
    list_iio_devices(dir, inner, ignored);
    if (inner.size() != 1) {
      not_found = inner.empty();
      error = printable(dir) + (inner.empty() ? " holds no IIO device"
                                              : " holds " + std::to_string(inner.size()) +
                                                    " IIO devices: give one of them");
      return false;
    }
    dir = inner[0].dir;
  }
  const auto status = device_.open(dir, error);
  not_found = status == IioDevice::OpenStatus::kMissing;
  return status == IioDevice::OpenStatus::kOpen;
}

bool IioSensor::start(std::string& error) {
  bool not_found = false;
  if (!open_device(error, not_found)) return false;
  if (config_.oversampling > 0 && !device_.set_pressure_oversampling(config_.oversampling, error)) {
    device_.close();
    return false;
  }
  return true;
}

IioSensor::Poll IioSensor::poll(double now_s) {
  Poll p;
  const std::string who = "IIO device " + config_.id;
  if (!device_.is_open()) {
    if (now_s < next_retry_s_) return p;
    next_retry_s_ = now_s + config_.reopen_s;
    std::string error;
    bool not_found = false;
    if (!open_device(error, not_found)) {
      const bool quiet = quiet_retry_ && not_found;
      quiet_retry_ = false;
      if (quiet || error == last_retry_error_) {
        last_retry_error_ = error;
        return p;
      }
      last_retry_error_ = error;
      p.kind = Poll::Kind::kMissing;
      p.text = who + " not available: " + error + "; retrying every " +
               seconds_text(config_.reopen_s) + " s";
      return p;
    }
    quiet_retry_ = false;
    last_retry_error_.clear();
    p.reopened = true;
    if (config_.oversampling > 0 &&
        !device_.set_pressure_oversampling(config_.oversampling, p.reopen_problem))
      p.reopen_problem = who + " (" + printable(device_.dir()) + "): " + p.reopen_problem;
  }
  std::string reason;
  switch (device_.read(p.reading, reason)) {
    case IioDevice::ReadStatus::kOk:
      reason = reading_problem(p.reading);
      if (reason.empty()) {
        p.kind = Poll::Kind::kSample;
        return p;
      }
      break;
    case IioDevice::ReadStatus::kBad:
      break;
    case IioDevice::ReadStatus::kGone:
      p.kind = Poll::Kind::kGone;
      p.text = who + " (" + printable(device_.dir()) + ") gone: " + reason + "; retrying every " +
               seconds_text(config_.reopen_s) + " s";
      device_.close();
      next_retry_s_ = now_s + config_.reopen_s;
      quiet_retry_ = true;
      last_retry_error_.clear();
      return p;
  }
  p.kind = Poll::Kind::kBad;
  p.text = who + " (" + printable(device_.dir()) + "): " + reason;
  return p;
}

}  // namespace ips::baro
