#include "depowder/node/cell.hpp"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <iterator>
#include <set>

#include "depowder/digest.hpp"

namespace depowder::node {

const std::vector<std::string> kModuleSections = {"perception", "tracker", "progress", "planner", "robot", "sim"};

double CameraConfig::fx() const { return focalLength(width, fov_h_deg); }
double CameraConfig::fy() const { return focalLength(height, fov_v_deg); }

namespace {

/// A camera's or part's name: it is part of channels (DEPTH_<camera>), heartbeat figures and the
/// tracker's state file, so letters, digits, '_', '-' and '.' only.
void readName(const YamlReader& r, std::string& name) {
  r.require("name", name);
  const bool plain = std::all_of(name.begin(), name.end(), [](unsigned char ch) {
    return std::isalnum(ch) || ch == '_' || ch == '-' || ch == '.';
  });
  if (name.empty() || name.size() > 64 || !plain)
    r.fail("name", "'" + name + "' must be 1 to 64 letters, digits, '_', '-' or '.'");
}

CameraConfig readCamera(const YamlReader& r) {
  CameraConfig c;
  readName(r, c.name);
  r.read("width", c.width, 16, 4096);
  r.read("height", c.height, 16, 4096);
  r.read("fov_h_deg", c.fov_h_deg, 10.0, 170.0);
  r.read("fov_v_deg", c.fov_v_deg, 10.0, 170.0);
  r.read("rate_hz", c.rate_hz, 0.1, 240.0);
  r.read("min_range", c.min_range, 0.0, 100.0);
  r.read("max_range", c.max_range, 0.01, 100.0);
  if (c.max_range <= c.min_range) r.fail("max_range", "must be greater than min_range");
  if (r.has("look_at")) {
    if (!r.has("position")) r.fail("position", "is required with look_at (where the camera is)");
    Eigen::Vector3d position = Eigen::Vector3d::Zero(), target = Eigen::Vector3d::Zero();
    r.readVector3("position", position);
    r.readVector3("look_at", target);
    if ((target - position).norm() < 1e-6) r.fail("look_at", "must differ from position");
    c.T_cell_camera = lookAt(position, target);
  } else {
    // No default: an identity pose puts the camera at the cell's origin looking up, and every cloud
    // it gives would land in the wrong place without a word.
    if (!r.has("pose")) r.fail("pose", "is required, or position and look_at (where the camera is in the cell)");
    r.readPose("pose", c.T_cell_camera);
  }
  const YamlReader n = r.child("noise");
  n.read("sigma_base", c.noise.sigma_base, 0.0, 0.1);
  n.read("sigma_per_m", c.noise.sigma_per_m, 0.0, 0.1);
  n.read("flying_pixel_prob", c.noise.flying_pixel_prob, 0.0, 1.0);
  n.read("grazing_dropout_deg", c.noise.grazing_dropout_deg, 0.0, 90.0);
  n.read("dropout_prob", c.noise.dropout_prob, 0.0, 1.0);
  n.finish();
  r.finish();
  return c;
}

PartConfig readPart(const YamlReader& r) {
  PartConfig p;
  readName(r, p.name);
  r.require("mesh", p.mesh);
  if (!p.mesh.empty() && p.mesh[0] != '/' && !r.directory().empty()) p.mesh = r.directory() + "/" + p.mesh;
  r.read("mesh_scale", p.mesh_scale, 1e-6, 1e3);
  r.readPose("initial_pose", p.T_cell_part_init);
  r.read("xi", p.xi, 0.0005, 0.1);
  r.read("density", p.density, 10.0, 30000.0);
  r.finish();
  return p;
}

CellConfig readCell(YamlReader root) {
  CellConfig cell{root.file(), {}, {}, {}, {}, root};
  const YamlReader lcm = root.child("lcm");
  lcm.read("url", cell.lcm.url);
  lcm.read("prefix", cell.lcm.prefix);
  lcm.finish();
  const YamlReader box = root.child("box");
  box.readVector3("size", cell.box.size);
  if (cell.box.size.minCoeff() <= 0 || cell.box.size.maxCoeff() > 5) box.fail("size", "each side must be in (0, 5] m");
  box.read("wall", cell.box.wall, 0.0, 0.2);
  box.finish();
  std::set<std::string> names;
  for (const YamlReader& c : root.items("cameras")) {
    cell.cameras.push_back(readCamera(c));
    if (!names.insert("camera:" + cell.cameras.back().name).second) c.fail("name", "is used twice");
  }
  for (const YamlReader& p : root.items("parts")) {
    cell.parts.push_back(readPart(p));
    if (!names.insert("part:" + cell.parts.back().name).second) p.fail("name", "is used twice");
  }
  for (const std::string& section : kModuleSections) root.child(section);  // read later by their modules
  root.finish();
  return cell;
}

}  // namespace

CellConfig loadCell(const std::string& path) { return readCell(YamlReader::loadFile(path)); }

CellConfig loadCellFromString(const std::string& text, const std::string& file) {
  return readCell(YamlReader::loadString(text, file));
}

Mesh loadPartMesh(const PartConfig& part) {
  try {
    return loadMesh(part.mesh, part.mesh_scale);
  } catch (const MeshError& e) {
    throw MeshError("part '" + part.name + "': " + e.what());
  }
}

void readEffector(const YamlReader& section, const std::string& key, std::vector<EffectorSection>& value) {
  // items() first: it marks the key as read, so a null `effector:` is not an unknown key.
  const std::vector<YamlReader> items = section.items(key);
  if (!section.has(key)) return;  // absent or null: the default
  value.clear();
  for (const YamlReader& item : items) {
    EffectorSection s;
    item.require("radius", s.radius);
    item.require("length", s.length);
    if (!(s.radius > 0 && s.radius <= 0.5)) item.fail("radius", "must be in (0, 0.5] m");
    if (!(s.length > 0 && s.length <= 2)) item.fail("length", "must be in (0, 2] m");
    item.finish();
    value.push_back(s);
  }
}

ToolConfig readTool(const CellConfig& cell) {
  ToolConfig tool;
  const YamlReader nozzle = cell.root.child("planner").child("nozzle");
  nozzle.read("radius", tool.nozzle_radius, 0.0, 0.5);
  nozzle.read("length", tool.tube_length, 0.0, 2.0);
  const YamlReader robot = cell.root.child("robot");
  robot.readPose("tool_offset", tool.T_flange_nozzle);
  tool.tube_length = std::max(tool.tube_length, tool.T_flange_nozzle.translation().norm());
  readEffector(robot, "effector", tool.effector);
  return tool;
}

std::string defaultCellPath() {
  if (const char* env = std::getenv("DEPOWDER_CELL")) return env;
  return DEPOWDER_DEFAULT_CELL;
}

LcmConfig toolBus(const std::string& tool, const std::string& cell, const std::optional<std::string>& url,
                  const std::optional<std::string>& prefix) {
  LcmConfig lcm;
  if (!url || !prefix) {
    try {
      const YamlReader root = YamlReader::loadFile(cell.empty() ? defaultCellPath() : cell);
      const YamlReader section = root.child("lcm");
      section.read("url", lcm.url);
      section.read("prefix", lcm.prefix);
      section.finish();
    } catch (const ConfigError& e) {
      if (!cell.empty()) throw;
      std::cerr << tool << ": " << e.what() << "; on the default bus, without a prefix" << std::endl;
      lcm = {};
    }
  }
  return {url.value_or(lcm.url), prefix.value_or(lcm.prefix)};
}

double cellModelId(const CellConfig& cell) {
  Digest d;
  auto pose = [&d](const Pose& T) {
    for (int k = 0; k < 16; ++k) d.add(T.matrix().data()[k]);
  };
  for (int k = 0; k < 3; ++k) d.add(cell.box.size[k]);
  d.add(cell.box.wall);
  for (const CameraConfig& c : cell.cameras) {
    d.add(c.name).add(c.width).add(c.height).add(c.fov_h_deg).add(c.fov_v_deg).add(c.rate_hz);
    d.add(c.min_range).add(c.max_range);
    pose(c.T_cell_camera);
  }
  for (const PartConfig& p : cell.parts) {
    d.add(p.name).add(p.mesh_scale).add(p.xi).add(p.density);
    pose(p.T_cell_part_init);
    std::ifstream in(p.mesh, std::ios::binary);  // the mesh by its bytes: its path may differ by host
    if (in)
      d.add(std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()));
    else
      d.add("unreadable " + p.mesh);
  }
  return d.value();
}

}  // namespace depowder::node
