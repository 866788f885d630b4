#include "setup.hpp"

#include <algorithm>
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

bool knownPart(const SimSetup& out, const std::string& name) {
  for (const auto& part : out.parts)
    if (part.name == name) return true;
  return false;
}

void readPhysics(const YamlReader& r, PhysicsConfig& p) {
  r.read("enabled", p.enabled);
  r.read("substep_hz", p.substep_hz, 60.0, 20000.0);
  r.read("gravity", p.gravity, 0.0, 100.0);
  r.read("friction", p.friction, 0.0, 5.0);
  r.read("nozzle_friction", p.nozzle_friction, 0.0, 5.0);
  r.read("restitution", p.restitution, 0.0, 1.0);
  r.read("margin", p.margin, 0.0, 0.01);
  r.read("solver_iterations", p.solver_iterations, 1, 1000);
  r.read("contact_distance", p.contact_distance, 0.0, 0.05);
  r.read("mass_voxel", p.mass_voxel, 0.0002, 0.01);
  const YamlReader d = r.child("decomposition");
  d.read("voxel", p.decomposition.voxel, 0.0005, 0.02);
  d.read("tolerance", p.decomposition.tolerance, 0.0, 10.0);
  d.read("max_pieces", p.decomposition.max_pieces, 1, 256);
  d.finish();
  PowderForceConfig& f = p.powder;
  const YamlReader pr = r.child("powder");
  pr.read("density", f.density, 0.0, 20000.0);
  pr.read("bearing_factor", f.bearing_factor, 0.0, 1000.0);
  pr.read("passive_factor", f.passive_factor, 0.0, 1000.0);
  pr.read("shear_factor", f.shear_factor, 0.0, 10.0);
  pr.read("lateral_pressure", f.lateral_pressure, 0.0, 2.0);
  pr.read("drag_speed", f.drag_speed, 1e-4, 100.0);
  pr.read("footing_depth", f.footing_depth, 0.0, 0.1);
  pr.read("sample_spacing", f.sample_spacing, 0.001, 0.05);
  pr.read("iterations", f.iterations, 1, 1000);
  pr.read("displace", f.displace);
  pr.finish();
  r.finish();
}

void readMotions(const YamlReader& s, SimSetup& out) {
  for (const YamlReader& item : s.items("motions")) {
    SimSetup::PartMotion m;
    item.require("part", m.part);
    if (!knownPart(out, m.part)) item.fail("part", "names no part of the cell ('" + m.part + "')");
    if (item.has("linear") == item.has("turntable")) item.fail("", "needs exactly one of 'linear' or 'turntable'");
    if (item.has("linear")) {
      const YamlReader l = item.child("linear");
      m.motion.kind = Motion::Kind::kLinear;
      if (!l.has("velocity")) l.fail("velocity", "is required");
      l.readVector3("velocity", m.motion.velocity);
      if (m.motion.velocity.norm() > 10) l.fail("velocity", "is faster than 10 m/s");
      l.finish();
    } else {
      const YamlReader t = item.child("turntable");
      m.motion.kind = Motion::Kind::kTurntable;
      double rate_deg = 0;
      t.require("rate_deg", rate_deg);
      t.read("rate_deg", rate_deg, -3600.0, 3600.0);
      m.motion.rate = rate_deg * M_PI / 180.0;
      if (t.has("centre")) m.motion.centre = readVector2(t, "centre", Eigen::Vector2d::Zero());
      t.finish();
    }
    item.read("start", m.motion.start, 0.0, 1e6);
    double duration = -1;  // -1: until the end
    item.read("duration", duration, -1.0, 1e6);
    if (duration >= 0) m.motion.duration = duration;
    item.read("visibility", m.motion.visibility, -1.0, 1.0);
    item.finish();
    out.motions.push_back(m);
  }
}

void readFaults(const YamlReader& s, SimSetup& out) {
  for (const YamlReader& item : s.items("faults")) {
    SimSetup::Fault f;
    item.require("at", f.at);
    item.read("at", f.at, 0.0, 1e6);
    item.read("silence_camera", f.silence_camera);
    item.read("duration", f.duration, 0.0, 1e6);
    item.read("drop_controller", f.drop_controller);
    if (f.silence_camera.empty() == !f.drop_controller)
      item.fail("", "needs exactly one of 'silence_camera' or 'drop_controller: true'");
    if (!f.silence_camera.empty() && std::none_of(out.cameras.begin(), out.cameras.end(),
                                                  [&](const CameraModel& c) { return c.name == f.silence_camera; }))
      item.fail("silence_camera", "names no camera of the cell ('" + f.silence_camera + "')");
    item.finish();
    out.faults.push_back(f);
  }
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

  readPhysics(s.child("physics"), out.config.physics);
  readMotions(s, out);
  if (s.has("push")) {
    const YamlReader push_reader = s.child("push");
    SimSetup::Push push;
    push_reader.require("part", push.part);
    if (!knownPart(out, push.part)) push_reader.fail("part", "names no part of the cell ('" + push.part + "')");
    push_reader.read("azimuth_deg", push.azimuth_deg, -360.0, 360.0);
    push_reader.read("height", push.height, 0.0, 1.0);
    push_reader.read("offset", push.offset, -0.5, 0.5);
    PushSpec& spec = push.spec;
    push_reader.read("speed", spec.speed, 1e-4, 1.0);
    push_reader.read("approach_speed", spec.approach_speed, 1e-4, 1.0);
    push_reader.read("clearance", spec.clearance, 0.0, 0.5);
    push_reader.read("gap", spec.gap, 0.0, 0.1);
    push_reader.read("tip_below", spec.tip_below, 0.0, 0.1);
    push_reader.read("wall_gap", spec.wall_gap, 0.0, 0.05);
    push_reader.read("stall_time", spec.stall_time, 0.1, 600.0);
    push_reader.read("settle", spec.settle, 0.0, 600.0);
    push_reader.read("steer", spec.steer);
    push_reader.finish();
    out.push = push;
  }

  s.readChoice("arm", out.arm, {"script", "emulator"});
  s.read("emulator_bind", out.emulator_bind);
  readFaults(s, out);
  for (const YamlReader& item : s.items("camera_truth")) {
    std::string name;
    item.require("camera", name);
    const auto cam =
        std::find_if(out.cameras.begin(), out.cameras.end(), [&](const CameraModel& c) { return c.name == name; });
    if (cam == out.cameras.end()) item.fail("camera", "names no camera of the cell ('" + name + "')");
    if (!item.has("pose")) item.fail("pose", "is required (where the camera really is)");
    if (cam->T_cell_camera_claimed) item.fail("camera", "is given twice");
    cam->T_cell_camera_claimed = cam->T_cell_camera;
    item.readPose("pose", cam->T_cell_camera);
    item.finish();
  }
  if (const std::string why = faultsProblem(out); !why.empty()) s.fail("faults", why);

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

}  // namespace

CameraModel cameraModelOf(const node::CameraConfig& c) {
  // The intrinsics of node::CameraConfig (focalLength), so DEPTH_* carries those the cell expects.
  CameraModel m = CameraModel::fromFov(c.name, c.width, c.height, c.fov_h_deg, c.fov_v_deg, c.T_cell_camera);
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

namespace {

// What a cell file gives the simulator besides its sim section: LCM, box, cameras, parts.
SimSetup cellSetup(const node::CellConfig& cell) {
  SimSetup out;
  out.cell_file = cell.file;
  out.lcm = cell.lcm;
  out.box.size = cell.box.size;
  out.box.wall = cell.box.wall;
  for (const auto& c : cell.cameras) out.cameras.push_back(cameraModelOf(c));
  for (const auto& p : cell.parts)
    out.parts.push_back({p.name, node::loadPartMesh(p), p.T_cell_part_init, p.density});
  return out;
}

}  // namespace

std::string faultsProblem(const SimSetup& setup) {
  for (const SimSetup::Fault& f : setup.faults)
    if (f.drop_controller && setup.arm != "emulator")
      return "drop_controller (the fault at t = " + std::to_string(f.at) + " s) needs the emulator (arm: emulator)";
  return "";
}

SimSetup simSetupOf(const node::CellConfig& cell) {
  SimSetup out = cellSetup(cell);
  out.sim_file = cell.file;
  readSimSection(cell.root.child("sim"), out);
  return out;
}

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
  if (!overlay) return simSetupOf(cell);
  SimSetup out = cellSetup(cell);
  out.sim_file = scenario_path;
  readSimSection(overlay->child("sim", true), out);
  overlay->finish();
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
  for (const auto& m : setup.motions) world->setPartMotion(world->partIndex(m.part), m.motion);
  return world;
}

std::unique_ptr<PushScript> makePushScript(const SimSetup& setup, const World& world) {
  if (!setup.push) return nullptr;
  const SimSetup::Push& p = *setup.push;
  PushSpec spec = pushFrom(world, world.partIndex(p.part), p.azimuth_deg, p.height, p.offset);
  const PushSpec& s = p.spec;
  spec.speed = s.speed;
  spec.approach_speed = s.approach_speed;
  spec.clearance = s.clearance;
  spec.gap = s.gap;
  spec.tip_below = s.tip_below;
  spec.wall_gap = s.wall_gap;
  spec.stall_time = s.stall_time;
  spec.settle = s.settle;
  spec.steer = s.steer;
  return std::make_unique<PushScript>(world, spec);
}

}  // namespace depowder::sim
