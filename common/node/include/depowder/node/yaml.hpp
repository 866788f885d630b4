// Reading YAML into plain config structs, with errors that name the file, the key
// and the allowed range. Keys mirror the struct fields; a key the reader was never
// asked for is an error (finish()), so a typo cannot pass silently.
#pragma once

#include <yaml-cpp/yaml.h>

#include <Eigen/Core>
#include <memory>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "depowder/geometry.hpp"

namespace depowder::node {

class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class YamlReader {
 public:
  /// Parses a file. Throws ConfigError for a missing or unparsable file.
  static YamlReader loadFile(const std::string& path);
  /// Parses a string (tests); `file` names it in errors.
  static YamlReader loadString(const std::string& text, const std::string& file = "<string>");

  const std::string& file() const { return file_; }
  /// Directory of the file, for resolving relative paths ("" for strings).
  std::string directory() const;
  /// Dotted path of this node, e.g. "tracker" or "parts[1]".
  const std::string& path() const { return path_; }

  bool has(const std::string& key) const;

  /// Reads `key` into `value` if present (keeps the default otherwise).
  template <class T>
  void read(const std::string& key, T& value) const {
    if (const YAML::Node n = lookup(key)) value = convert<T>(n, key);
  }
  /// Same, and the value must lie in [lo, hi].
  template <class T>
  void read(const std::string& key, T& value, T lo, T hi) const {
    read(key, value);
    if (!(value >= lo && value <= hi))  // NaN (".nan") is out of every range
      fail(key, "value " + show(value) + " is out of range [" + show(lo) + ", " + show(hi) + "]");
  }
  /// Reads a key that must be present.
  template <class T>
  void require(const std::string& key, T& value) const {
    if (!has(key)) fail(key, "is required");
    read(key, value);
  }
  /// A list of exactly 3 numbers.
  void readVector3(const std::string& key, Eigen::Vector3d& value) const;
  /// A pose: {xyz: [x, y, z] (m), rpy_deg: [roll, pitch, yaw]} or {xyz, quat_wxyz: [w, x, y, z]}.
  void readPose(const std::string& key, Pose& value) const;
  /// One of `allowed` (strings).
  void readChoice(const std::string& key, std::string& value, const std::vector<std::string>& allowed) const;

  /// A map below this one (must exist if `required`; an empty reader otherwise).
  YamlReader child(const std::string& key, bool required = false) const;
  /// The items of a list below this one.
  std::vector<YamlReader> items(const std::string& key) const;

  /// Throws ConfigError naming every key of this map that nobody read.
  void finish() const;

  [[noreturn]] void fail(const std::string& key, const std::string& what) const;

 private:
  YamlReader(YAML::Node node, std::string file, std::string path);
  YAML::Node lookup(const std::string& key) const;
  template <class T>
  T convert(const YAML::Node& n, const std::string& key) const {
    try {
      return n.as<T>();
    } catch (const YAML::Exception&) {
      fail(key, "cannot be read as " + typeName<T>() + " (line " + std::to_string(n.Mark().line + 1) + ")");
    }
  }
  template <class T>
  static std::string typeName();
  template <class T>
  static std::string show(const T& v);

  YAML::Node node_;
  std::string file_;
  std::string path_;
  std::shared_ptr<std::set<std::string>> used_;
};

template <class T>
std::string YamlReader::typeName() {
  if constexpr (std::is_same_v<T, bool>)
    return "true/false";
  else if constexpr (std::is_integral_v<T>)
    return "an integer";
  else if constexpr (std::is_floating_point_v<T>)
    return "a number";
  else if constexpr (std::is_same_v<T, std::string>)
    return "a string";
  else
    return "the expected type";
}

template <class T>
std::string YamlReader::show(const T& v) {
  if constexpr (std::is_arithmetic_v<T>) {
    std::string s = std::to_string(v);
    if constexpr (std::is_floating_point_v<T>) {
      s.erase(s.find_last_not_of('0') + 1);
      if (!s.empty() && s.back() == '.') s.pop_back();
    }
    return s;
  } else {
    return std::string(v);
  }
}

}  // namespace depowder::node
