#include "core/yaml_fields.hpp"

#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>

#include "core/text_escape.hpp"

namespace ips {

namespace {
// A bound as a reader would write it: 1e+06, 0.001, 9.7.
std::string format_bound(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}
}  // namespace

YamlField YamlField::operator[](const std::string& key) const {
  std::string p = path_.empty() ? key : path_ + "." + key;
  if (!node_.IsMap()) {
    if (defined()) fail("expected a map with key '" + key + "'");
    return YamlField(YAML::Node(YAML::NodeType::Undefined), origin_, p);
  }
  // A missing key gives yaml-cpp's "zombie" node, on which most calls throw; hand out a valid
  // undefined node instead.
  // (yaml-cpp's Node::operator= assigns through the reference, so never rebind a Node.)
  const YAML::Node child = node_[key];
  return child.IsDefined() ? YamlField(child, origin_, p)
                           : YamlField(YAML::Node(YAML::NodeType::Undefined), origin_, p);
}

YamlField YamlField::operator[](size_t index) const {
  std::string p = path_ + "[" + std::to_string(index) + "]";
  return index < size() ? YamlField(node_[index], origin_, p)
                        : YamlField(YAML::Node(YAML::NodeType::Undefined), origin_, p);
}

void YamlField::fail(const std::string& reason) const {
  std::string where = origin_;
  if (node_.IsDefined() && node_.Mark().line >= 0) {
    where += ":" + std::to_string(node_.Mark().line + 1);
  }
  throw ConfigError(where + ": " + (path_.empty() ? "" : path_ + ": ") + reason);
}

void YamlField::check_keys(std::initializer_list<const char*> known) const {
  if (!node_.IsMap()) return;
  for (const auto& kv : node_) {
    const std::string key = kv.first.IsScalar() ? kv.first.Scalar() : "?";
    bool ok = false;
    for (const char* k : known) ok = ok || key == k;
    if (ok) continue;
    std::string list;
    for (const char* k : known) list += (list.empty() ? "" : ", ") + std::string(k);
    YamlField(kv.first, origin_, path_.empty() ? key : path_ + "." + key)
        .fail("unknown field (known: " + list + ")");
  }
}

double YamlField::as_double() const {
  if (!node_.IsScalar()) fail(defined() ? "expected a number" : "field is required");
  try {
    double v = node_.as<double>();
    if (!std::isfinite(v)) fail("expected a finite number, got '" + node_.Scalar() + "'");
    return v;
  } catch (const YAML::Exception&) {
    fail("expected a number, got '" + node_.Scalar() + "'");
  }
}

int64_t YamlField::as_int() const {
  if (!node_.IsScalar()) fail(defined() ? "expected an integer" : "field is required");
  try {
    return node_.as<int64_t>();
  } catch (const YAML::Exception&) {
    fail("expected an integer, got '" + node_.Scalar() + "'");
  }
}

bool YamlField::as_bool() const {
  if (!node_.IsScalar()) fail(defined() ? "expected true or false" : "field is required");
  try {
    return node_.as<bool>();
  } catch (const YAML::Exception&) {
    fail("expected true or false, got '" + node_.Scalar() + "'");
  }
}

std::string YamlField::as_string() const {
  if (!node_.IsScalar()) fail(defined() ? "expected a string" : "field is required");
  return node_.Scalar();
}

Eigen::Vector3d YamlField::as_vec3() const {
  if (!node_.IsSequence() || node_.size() != 3) fail("expected a list of 3 numbers [x, y, z]");
  return {(*this)[0].as_double(), (*this)[1].as_double(), (*this)[2].as_double()};
}

Eigen::Vector2d YamlField::as_vec2() const {
  if (!node_.IsSequence() || node_.size() != 2) fail("expected a list of 2 numbers [x, y]");
  return {(*this)[0].as_double(), (*this)[1].as_double()};
}

double YamlField::get_double(const std::string& key, double fallback) const {
  auto f = (*this)[key];
  return f.defined() ? f.as_double() : fallback;
}
int64_t YamlField::get_int(const std::string& key, int64_t fallback) const {
  auto f = (*this)[key];
  return f.defined() ? f.as_int() : fallback;
}
double YamlField::get_double_in(const std::string& key, double fallback, double lo,
                                double hi) const {
  const double v = get_double(key, fallback);
  if (!(v >= lo && v <= hi))
    (*this)[key].fail("must be in [" + format_bound(lo) + ", " + format_bound(hi) + "]");
  return v;
}
int64_t YamlField::get_int_in(const std::string& key, int64_t fallback, int64_t lo,
                              int64_t hi) const {
  const int64_t v = get_int(key, fallback);
  if (v < lo || v > hi)
    (*this)[key].fail("must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
  return v;
}
bool YamlField::get_bool(const std::string& key, bool fallback) const {
  auto f = (*this)[key];
  return f.defined() ? f.as_bool() : fallback;
}
std::string YamlField::get_string(const std::string& key, const std::string& fallback) const {
  auto f = (*this)[key];
  return f.defined() ? f.as_string() : fallback;
}
YamlField YamlField::required(const std::string& key) const {
  auto f = (*this)[key];
  if (!f.defined()) {
    // Point at the parent, which exists.
    std::string where = origin_;
    if (node_.IsDefined() && node_.Mark().line >= 0) where += ":" + std::to_string(node_.Mark().line + 1);
    throw ConfigError(where + ": " + f.path() + ": field is required");
  }
  return f;
}

YamlField parse_yaml_text(const std::string& text, const std::string& origin) {
  try {
    return YamlField(YAML::Load(text), origin, "");
  } catch (const YAML::ParserException& e) {
    throw ConfigError(origin + ":" + std::to_string(e.mark.line + 1) + ":" +
                      std::to_string(e.mark.column + 1) + ": YAML syntax error: " + e.msg);
  }
}

std::string read_text_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw ConfigError(path + ": cannot read: " + std::strerror(errno));
  std::stringstream ss;
  ss << in.rdbuf();
  if (in.bad()) throw ConfigError(path + ": cannot read: " + std::strerror(errno));
  return ss.str();
}

bool write_text_file(const std::string& path, const std::string& text, std::string& error) {
  errno = 0;
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (out) out.write(text.data(), static_cast<std::streamsize>(text.size()));
  if (out) out.close();
  if (out) return true;
  error = "cannot write '" + printable(path) + "': " + (errno ? std::strerror(errno) : "write failed");
  return false;
}

YamlField load_yaml_file(const std::string& path) {
  return parse_yaml_text(read_text_file(path), path);
}

}  // namespace ips
