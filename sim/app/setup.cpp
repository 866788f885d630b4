#include "setup.hpp"

#include <cmath>

#include "depowder/mesh.hpp"
#include "depowder/node/yaml.hpp"

namespace depowder::sim {
namespace {

using node::YamlReader;

Tool readTool(const YamlReader& r, const std::string& key, Tool fallback) {
  std::string s = toString(fallback);
  r.readChoice(key, s, {"off", "vacuum", "air"});
  return s == "vacuum" ? Tool::kVacuum : s == "air" ? Tool::kAir : Tool::kOff;
}

Eigen::Vector2d readVector2(const YamlReader& r, const std::string& key, Eigen::Vector2d value) {
  std::vector<double> v{value.x(), value.y()};
  r.read(key, v);
  if (v.size() != 2 || !std::isfinite(v[0]) || !std::isfinite(v[1])) r.fail(key, "must be a list of 2 finite numbers");
  return {v[0], v[1]};
}

Orbit readOrbit(const YamlReader& r) {
  Orbit o;
  o.centre = readVector2(r, "centre", o.centre);
  o.radii = readVector2(r, "radii", o.radii);
  if (o.radii.minCoeff() < 0) r.fail("radii", "must not be negative");
  r.read("height", o.height, -1.0, 5.0);
  r.read("period", o.period, -3600.0, 3600.0);
  if (o.period == 0) r.fail("period", "must not be 0");
  r.read("start_deg", o.start_deg, -360.0, 360.0);
  r.read("tilt_deg", o.tilt_deg, 0.0, 90.0);
  r.read("descend_per_rev", o.descend_per_rev, 0.0, 1.0);
  r.read("min_height", o.min_height, -1.0, 5.0);
  r.read("revolutions", o.revolutions, 1e-3, 1e6);
  o.tool = readTool(r, "tool", o.tool);
  r.finish();
  return o;
}

std::vector<Waypoint> readWaypoints(const YamlReader& r, const std::string& key) {
  std::vector<Waypoint> out;
  for (const YamlReader& w : r.items(key)) {
    Waypoint p;
    w.require("t", p.t);
    if (!out.empty() && !(p.t > out.back().t)) w.fail("t", "must be later than the previous waypoint's");
    Eigen::Vector3d xyz = Eigen::Vector3d::Zero(), spray(0, 0, -1);
    if (!w.has("xyz")) w.fail("xyz", "is required");
    w.readVector3("xyz", xyz);
    w.readVector3("spray", spray);
    if (spray.norm() < 1e-9) w.fail("spray", "must be a non-zero direction");
    p.T_cell_nozzle = nozzlePose(xyz, spray);
    p.tool = readTool(w, "tool", Tool::kOff);
    w.finish();
    out.push_back(p);
  }
  if (out.empty()) r.fail(key, "needs at least one waypoint");
  return out;
}

void readSimSection(const YamlReader& s, SimSetup& out) {
  int seed = static_cast<int>(out.seed);
  s.read("seed", seed, 0, 2147483647);
  out.seed = static_cast<std::uint32_t>(seed);
  s.read("step_hz", out.step_hz, 10.0, 10000.0);
  s.read("truth_hz", out.truth_hz, 0.1, 1000.0);

  PowderConfig& p = out.config.powder;
  const YamlReader pr = s.child("powder");
  pr.read("cell_size", p.cell_size, 0.0005, 0.05);
  pr.read("cover", p.cover, 0.0, 1.0);
  pr.read("level", p.level, -1.0, 5.0);
  pr.read("repose_deg", p.repose_deg, 5.0, 60.0);
  pr.read("relax_sweeps", p.relax_sweeps, 0, 10000);
  pr.read("relax_tolerance", p.relax_tolerance, 0.0, 0.01);
  pr.read("bare_thickness", p.bare_thickness, 0.0, 0.01);
  pr.finish();

  const YamlReader vis = s.child("visibility");
  if (vis.has("part") || vis.has("eta")) {
    vis.require("part", out.visibility_part);
    vis.require("eta", out.visibility_eta);
    vis.read("eta", out.visibility_eta, 0.0, 1.0);
    bool known = false;
    for (const auto& part : out.parts) known = known || part.name == out.visibility_part;
    if (!known) vis.fail("part", "names no part of the cell ('" + out.visibility_part + "')");
  }
  vis.finish();

  VacuumConfig& v = out.config.vacuum;
  const YamlReader vr = s.child("vacuum");
  vr.read("radius", v.radius, 0.001, 0.2);
  vr.read("standoff", v.standoff, 0.0, 0.2);
  vr.read("layer_depth", v.layer_depth, 0.0001, 0.1);
  vr.read("sink_rate", v.sink_rate, 0.0001, 10.0);
  vr.read("residue", v.residue, 0.0, 0.02);
  vr.finish();

  AirConfig& a = out.config.air;
  const YamlReader ar = s.child("air");
  ar.read("radius", a.radius, 0.001, 0.3);
  ar.read("reach", a.reach, 0.0, 1.0);
  ar.read("clear_rate", a.clear_rate, 0.0001, 10.0);
  ar.read("extra_depth", a.extra_depth, 0.0, 0.05);
  ar.finish();

  const YamlReader nr = s.child("nozzle");
  nr.read("radius", out.config.nozzle.radius, 0.001, 0.2);
  nr.read("length", out.config.nozzle.length, 0.01, 1.0);
  nr.read("mesh", out.nozzle_mesh);
  if (!out.nozzle_mesh.empty() && out.nozzle_mesh[0] != '/' && !nr.directory().empty())
    out.nozzle_mesh = nr.directory() + "/" + out.nozzle_mesh;
  nr.read("mesh_scale", out.nozzle_mesh_scale, 1e-6, 1e3);
  nr.readPose("mesh_pose", out.T_nozzle_mesh);
  nr.finish();

  const YamlReader tr = s.child("truth");
  tr.read("band_inner", out.config.truth.band_inner, 0.0, 0.2);
  tr.read("band_outer", out.config.truth.band_outer, 0.0, 0.3);
  if (out.config.truth.band_outer <= out.config.truth.band_inner) tr.fail("band_outer", "must exceed band_inner");
  tr.finish();

  SceneConfig& sc = out.config.scene;
  const YamlReader cr = s.child("scene");
  cr.read("depth_unit", sc.depth_unit, 1e-5, 0.01);
  cr.read("table_size", sc.table_size, 0.0, 10.0);
  cr.read("contact_spacing", sc.contact_spacing, 0.0005, 0.05);
  double flying_edge = DepthNoise{}.flying_edge;
  cr.read("flying_edge", flying_edge, 0.0, 1.0);
  for (auto& cam : out.cameras) cam.noise.flying_edge = flying_edge;
  cr.finish();

  s.readChoice("arm", out.arm, {"script", "emulator"});
  s.read("emulator_bind", out.emulator_bind);

  const YamlReader sr = s.child("script");
  sr.read("loop", out.script_loop);
  for (const YamlReader& item : sr.items("segments")) {
    ScriptSegment seg;
    if (item.has("orbit") == item.has("waypoints")) item.fail("", "needs exactly one of 'orbit' or 'waypoints'");
    if (item.has("orbit")) {
      seg.kind = ScriptSegment::Kind::kOrbit;
      seg.orbit = readOrbit(item.child("orbit"));
    } else {
      seg.kind = ScriptSegment::Kind::kWaypoints;
      seg.waypoints = readWaypoints(item, "waypoints");
    }
    item.finish();
    out.script.push_back(std::move(seg));
  }
  sr.finish();
  s.finish();
}

CameraModel toCamera(const node::CameraConfig& c) {
  CameraModel m = CameraModel::fromFov(c.name, c.width, c.height, c.fov_h_deg, c.fov_v_deg, c.T_cell_camera);
  // The same formulas as node::CameraConfig, so DEPTH_* carries the intrinsics the cell expects.
  m.fx = c.fx();
  m.fy = c.fy();
  m.cx = c.cx();
  m.cy = c.cy();
  m.min_range = c.min_range;
  m.max_range = c.max_range;
  m.rate_hz = c.rate_hz;
  m.noise.sigma_base = c.noise.sigma_base;
  m.noise.sigma_per_m = c.noise.sigma_per_m;
  m.noise.flying_pixel_prob = c.noise.flying_pixel_prob;
  m.noise.grazing_dropout_deg = c.noise.grazing_dropout_deg;
  m.noise.dropout_prob = c.noise.dropout_prob;
  return m;
}

}  // namespace

SimSetup loadSimSetup(const std::string& cell_path, const std::string& scenario_path) {
  std::string cell_file = cell_path;
  std::unique_ptr<YamlReader> overlay;
  if (!scenario_path.empty()) {
    YamlReader scenario = YamlReader::loadFile(scenario_path);
    if (scenario.has("sim") && !scenario.has("box") && !scenario.has("cameras") && !scenario.has("parts"))
      overlay = std::make_unique<YamlReader>(scenario);
    else
      cell_file = scenario_path;
  }
  const node::CellConfig cell = node::loadCell(cell_file);
  SimSetup out;
  out.cell_file = cell.file;
  out.lcm = cell.lcm;
  out.box.size = cell.box.size;
  out.box.wall = cell.box.wall;
  for (const auto& c : cell.cameras) out.cameras.push_back(toCamera(c));
  for (const auto& p : cell.parts)
    out.parts.push_back({p.name, loadMesh(p.mesh, p.mesh_scale), p.T_cell_part_init, p.density});
  if (overlay) {
    out.sim_file = scenario_path;
    readSimSection(overlay->child("sim", true), out);
    overlay->finish();
  } else {
    out.sim_file = cell.file;
    readSimSection(cell.root.child("sim"), out);
  }
  return out;
}

std::unique_ptr<World> makeWorld(const SimSetup& setup) {
  auto world = std::make_unique<World>(setup.config, setup.box, setup.parts, setup.cameras, setup.seed);
  if (!setup.nozzle_mesh.empty()) {
    Mesh m = transformed(loadMesh(setup.nozzle_mesh, setup.nozzle_mesh_scale), setup.T_nozzle_mesh);
    world->setNozzleMesh(std::move(m));
  }
  if (!setup.visibility_part.empty())
    world->digToVisibility(world->partIndex(setup.visibility_part), setup.visibility_eta);
  return world;
}

}  // namespace depowder::sim
