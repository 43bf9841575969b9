#include "drivers/baro/sysfs_value.hpp"

#include <cmath>

#include "core/device_text.hpp"

namespace ips::baro {

namespace {

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; }

bool attribute_number(std::string_view prefix, const char* suffix, std::string_view text,
                      double& value, std::string& reason) {
  if (parse_sysfs_number(text, value, reason)) return true;
  reason = std::string(prefix) + suffix + ": " + reason;
  return false;
}

}  // namespace

bool parse_sysfs_number(std::string_view text, double& value, std::string& reason) {
  while (!text.empty() && is_space(text.front())) text.remove_prefix(1);
  while (!text.empty() && is_space(text.back())) text.remove_suffix(1);
  if (text.empty()) {
    reason = "empty";
    return false;
  }
  // parse_decimal takes exactly the kernel's forms: digits, an optional '-', at most one '.'.
  if (!parse_decimal(text, value)) {
    reason = quoted_field(text) + " is not a number";
    return false;
  }
  return true;
}

bool iio_channel_value(const IioChannelText& c, double& value, std::string& reason) {
  if (c.input) return attribute_number(c.prefix, "_input", *c.input, value, reason);
  if (!c.raw || !c.scale) {
    reason = std::string(c.prefix) + ": neither _input nor _raw with _scale";
    return false;
  }
  double raw = 0, scale = 0, offset = 0;
  if (!attribute_number(c.prefix, "_raw", *c.raw, raw, reason) ||
      !attribute_number(c.prefix, "_scale", *c.scale, scale, reason) ||
      (c.offset && !attribute_number(c.prefix, "_offset", *c.offset, offset, reason)))
    return false;
  const double v = (raw + offset) * scale;
  if (!std::isfinite(v)) {
    reason = std::string(c.prefix) + ": (raw + offset) * scale is not finite";
    return false;
  }
  value = v;
  return true;
}

}  // namespace ips::baro
