#include "depowder/node/yaml.hpp"

#include <algorithm>
#include <cmath>

namespace depowder::node {

YamlReader::YamlReader(YAML::Node node, std::string file, std::string path)
    : node_(std::move(node)),
      file_(std::move(file)),
      path_(std::move(path)),
      used_(std::make_shared<std::set<std::string>>()) {}

YamlReader YamlReader::loadFile(const std::string& path) {
  try {
    return YamlReader(YAML::LoadFile(path), path, "");
  } catch (const YAML::BadFile&) {
    throw ConfigError(path + ": cannot open the file");
  } catch (const YAML::Exception& e) {
    throw ConfigError(path + ": not valid YAML: " + e.what());
  }
}

YamlReader YamlReader::loadString(const std::string& text, const std::string& file) {
  try {
    return YamlReader(YAML::Load(text), file, "");
  } catch (const YAML::Exception& e) {
    throw ConfigError(file + ": not valid YAML: " + e.what());
  }
}

std::string YamlReader::directory() const {
  const auto slash = file_.find_last_of('/');
  return slash == std::string::npos ? (file_.rfind('<', 0) == 0 ? "" : ".") : file_.substr(0, slash);
}

void YamlReader::fail(const std::string& key, const std::string& what) const {
  const std::string full = path_.empty() ? key : key.empty() ? path_ : path_ + "." + key;
  throw ConfigError(file_ + ": '" + full + "' " + what);
}

bool YamlReader::has(const std::string& key) const {
  return node_.IsMap() && node_[key].IsDefined() && !node_[key].IsNull();
}

// An absent key (or a null value) reads as an undefined node, which `!n` detects.
YAML::Node YamlReader::lookup(const std::string& key) const {
  const YAML::Node absent(YAML::NodeType::Undefined);
  if (!node_.IsDefined() || node_.IsNull()) return absent;
  if (!node_.IsMap()) fail("", "must be a map of keys");
  used_->insert(key);
  const YAML::Node n = node_[key];
  return n.IsDefined() && !n.IsNull() ? n : absent;
}

void YamlReader::readVector3(const std::string& key, Eigen::Vector3d& value) const {
  const YAML::Node n = lookup(key);
  if (!n) return;
  if (!n.IsSequence() || n.size() != 3) fail(key, "must be a list of 3 numbers");
  for (int i = 0; i < 3; ++i) {
    value[i] = convert<double>(n[i], key);
    if (!std::isfinite(value[i])) fail(key, "must be finite");
  }
}

void YamlReader::readPose(const std::string& key, Pose& value) const {
  if (!has(key)) {
    used_->insert(key);
    return;
  }
  const YamlReader p = child(key, true);
  Eigen::Vector3d xyz = value.translation();
  p.readVector3("xyz", xyz);
  Eigen::Quaterniond q(value.linear());
  if (p.has("rpy_deg") && p.has("quat_wxyz")) p.fail("", "give rpy_deg or quat_wxyz, not both");
  if (p.has("rpy_deg")) {
    Eigen::Vector3d rpy;
    p.readVector3("rpy_deg", rpy);
    rpy *= M_PI / 180.0;
    value = makePoseRpy(xyz, rpy.x(), rpy.y(), rpy.z());
  } else {
    if (p.has("quat_wxyz")) {
      const YAML::Node n = p.lookup("quat_wxyz");
      if (!n.IsSequence() || n.size() != 4) p.fail("quat_wxyz", "must be a list of 4 numbers");
      const auto at = [&](int i) { return p.convert<double>(n[i], "quat_wxyz"); };  // errors name the list
      q = Eigen::Quaterniond(at(0), at(1), at(2), at(3));
      if (!q.coeffs().allFinite() || q.norm() < 1e-9) p.fail("quat_wxyz", "must be a finite non-zero quaternion");
    }
    value = makePose(xyz, q);
  }
  p.finish();
}

void YamlReader::readChoice(const std::string& key, std::string& value, const std::vector<std::string>& allowed) const {
  read(key, value);
  if (std::find(allowed.begin(), allowed.end(), value) == allowed.end()) {
    std::string list;
    for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
    fail(key, "is '" + value + "'; allowed: " + list);
  }
}

YamlReader YamlReader::child(const std::string& key, bool required) const {
  const YAML::Node n = lookup(key);
  const std::string p = path_.empty() ? key : path_ + "." + key;
  if (!n) {
    if (required) fail(key, "is required");
    return YamlReader(YAML::Node(), file_, p);
  }
  if (!n.IsMap()) fail(key, "must be a map of keys");
  return YamlReader(n, file_, p);
}

std::vector<YamlReader> YamlReader::items(const std::string& key) const {
  const YAML::Node n = lookup(key);
  std::vector<YamlReader> out;
  if (!n) return out;
  if (!n.IsSequence()) fail(key, "must be a list");
  const std::string p = path_.empty() ? key : path_ + "." + key;
  for (std::size_t i = 0; i < n.size(); ++i) out.push_back(YamlReader(n[i], file_, p + "[" + std::to_string(i) + "]"));
  return out;
}

void YamlReader::finish() const {
  if (!node_ || !node_.IsMap()) return;
  std::string unknown;
  for (const auto& kv : node_) {
    // A key is a name; a list or map in its place (YAML's `? [a, b]`) is never a known key.
    const std::string k = kv.first.IsScalar()
                              ? kv.first.Scalar()
                              : "(a list or map as a key, line " + std::to_string(kv.first.Mark().line + 1) + ")";
    if (!used_->count(k)) unknown += (unknown.empty() ? "'" : ", '") + k + "'";
  }
  if (unknown.empty()) return;
  std::string known;
  for (const auto& k : *used_) known += (known.empty() ? "" : ", ") + k;
  throw ConfigError(file_ + ": unknown key " + unknown + (path_.empty() ? "" : " in '" + path_ + "'") +
                    " (known keys: " + known + ")");
}

}  // namespace depowder::node
