#pragma once
// Reading typed fields out of YAML with errors that name the file, line, field and reason:
// "lab.yaml:12: anchors[2].position: expected a list of 3 numbers".
#include <yaml-cpp/yaml.h>

#include <Eigen/Core>
#include <initializer_list>
#include <stdexcept>
#include <string>

namespace ips {

struct ConfigError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// A YAML node with the place it came from, for error messages.
class YamlField {
 public:
  YamlField(YAML::Node node, std::string origin, std::string path)
      : node_(std::move(node)), origin_(std::move(origin)), path_(std::move(path)) {}
  YamlField(const YamlField&) = default;
  // YAML::Node's operator= writes through to the node it refers to; a YamlField must rebind.
  YamlField& operator=(const YamlField& other) {
    node_.reset(other.node_);
    origin_ = other.origin_;
    path_ = other.path_;
    return *this;
  }

  const YAML::Node& node() const { return node_; }
  const std::string& path() const { return path_; }
  const std::string& origin() const { return origin_; }
  bool defined() const { return node_.IsDefined() && !node_.IsNull(); }

  YamlField operator[](const std::string& key) const;
  YamlField operator[](size_t index) const;
  size_t size() const { return node_.IsSequence() ? node_.size() : 0; }
  bool is_map() const { return node_.IsMap(); }
  bool is_sequence() const { return node_.IsSequence(); }

  [[noreturn]] void fail(const std::string& reason) const;
  // Fails on a key of this map that is not in `known`: a misspelt field must not silently fall
  // back to its default.
  void check_keys(std::initializer_list<const char*> known) const;

  double as_double() const;
  int64_t as_int() const;
  bool as_bool() const;
  std::string as_string() const;
  Eigen::Vector3d as_vec3() const;           // [x, y, z]
  Eigen::Vector2d as_vec2() const;           // [x, y]

  double get_double(const std::string& key, double fallback) const;
  int64_t get_int(const std::string& key, int64_t fallback) const;
  bool get_bool(const std::string& key, bool fallback) const;
  std::string get_string(const std::string& key, const std::string& fallback) const;
  // get_double / get_int, failing with "must be in [lo, hi]" outside the bounds (every
  // parameter is bounded: a SITE message on the bus is outside input).
  double get_double_in(const std::string& key, double fallback, double lo, double hi) const;
  int64_t get_int_in(const std::string& key, int64_t fallback, int64_t lo, int64_t hi) const;
  // Fails with "field is required" when absent.
  YamlField required(const std::string& key) const;

 private:
  YAML::Node node_;
  std::string origin_;
  std::string path_;
};

// Parses YAML text; a syntax error becomes ConfigError "origin:line:col: reason".
YamlField parse_yaml_text(const std::string& text, const std::string& origin);
// Reads a whole file; failure gives ConfigError "path: cannot read: reason".
std::string read_text_file(const std::string& path);
// Writes `text` to `path`, replacing it. False with "cannot write 'PATH': reason" in `error`
// (the path printable: escaped for a terminal).
bool write_text_file(const std::string& path, const std::string& text, std::string& error);
// Reads and parses a YAML file; unreadable files give ConfigError "path: cannot read: reason".
YamlField load_yaml_file(const std::string& path);

}  // namespace ips
