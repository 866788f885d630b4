#include "depowder/viewer/scene.hpp"

#include <cmath>
#include <cstdio>

#include "depowder/node/cell.hpp"
#include "depowder/node/convert.hpp"
#include "depowder/nozzle_plan_t.hpp"
#include "depowder/part_pose_t.hpp"
#include "depowder/point_cloud_t.hpp"
#include "depowder/progress_t.hpp"
#include "depowder/robot_state_t.hpp"
#include "depowder/sim_truth_t.hpp"

namespace depowder::viewer {

PartScene* Scene::find(const std::string& name) {
  for (PartScene& p : parts)
    if (p.name == name) return &p;
  return nullptr;
}

const PartScene* Scene::find(const std::string& name) const {
  for (const PartScene& p : parts)
    if (p.name == name) return &p;
  return nullptr;
}

PartScene& Scene::part(const std::string& name) {
  if (PartScene* p = find(name)) return *p;
  parts.push_back(PartScene{});
  parts.back().name = name;
  ++versions.parts;
  return parts.back();
}

Scene sceneFromCell(const node::CellConfig& cell) {
  Scene scene;
  scene.box_size = cell.box.size;
  for (const node::PartConfig& pc : cell.parts) {
    PartScene& p = scene.part(pc.name);
    p.mesh = std::make_shared<const Mesh>(node::loadPartMesh(pc));
    p.T_cell_part = pc.T_cell_part_init;  // drawn only once the tracker has spoken
  }
  scene.tool_mesh = std::make_shared<const Mesh>(toolOfCell(cell));
  return scene;
}

Mesh toolOfCell(const node::CellConfig& cell) {
  const node::ToolConfig c = node::readTool(cell);
  constexpr int kSegments = 24;
  Mesh tool = cylinderMesh(c.nozzle_radius, c.tube_length, kSegments);  // the tube, up from the tip
  const Pose T_nozzle_flange = c.T_flange_nozzle.inverse(Eigen::Isometry);
  for (const EffectorBody& e : effectorBodies(c.effector, c.T_flange_nozzle))
    append(tool, transformed(cylinderMesh(e.radius, e.length, kSegments), T_nozzle_flange * e.T_flange_end()));
  return tool;
}

void SceneModel::reject(const std::string& why) {
  ++rejected_.count;
  rejected_.last_reason = why;
}

void SceneModel::onPoints(const point_cloud_t& msg) {
  std::string why;
  if (msg.num_points != static_cast<std::int32_t>(msg.xyz.size())) return reject("POINTS: num_points mismatch");
  std::optional<Cloud> cloud = node::decodeCloud(msg, &why);
  if (!cloud) return reject("POINTS: " + why);
  scene_.cloud = std::move(*cloud);
  scene_.cloud_seq = msg.seq;
  scene_.cloud_utime = msg.utime;
  ++scene_.versions.cloud;
  ++scene_.versions.text;
}

void SceneModel::onPartPose(const part_pose_t& msg) {
  std::string why;
  const std::optional<Pose> T = node::fromMsg(msg.T_cell_part, &why);
  if (!T) return reject("PART_POSE " + msg.part + ": " + why);
  if (msg.part.empty()) return reject("PART_POSE: empty part name");
  const bool template_ok = std::isfinite(msg.template_resolution) && msg.template_resolution > 0 &&
                           msg.template_size == static_cast<std::int32_t>(msg.template_xyz.size());
  if (!template_ok && msg.template_size > 0) return reject("PART_POSE " + msg.part + ": invalid template header");
  PartScene& p = scene_.part(msg.part);
  p.has_estimate = true;
  p.T_cell_part = *T;
  p.track_status = msg.status;
  p.track_reason = msg.status_reason;
  p.method = msg.method;
  p.pose_utime = msg.utime;
  // The template is re-decoded only when its version changes (it is the same
  // points, in the part frame, until Alg. 2 re-derives it).
  if (msg.template_version != p.template_version || msg.template_updated) {
    p.template_points.clear();
    p.template_points.reserve(msg.template_xyz.size());
    for (const auto& q : msg.template_xyz)
      p.template_points.push_back(msg.template_resolution * Eigen::Vector3d(q[0], q[1], q[2]));
    p.template_version = msg.template_version;
    ++scene_.versions.templates;
  }
  ++scene_.versions.parts;
  ++scene_.versions.text;
}

void SceneModel::onProgress(const progress_t& msg) {
  if (msg.part.empty()) return reject("PROGRESS: empty part name");
  if (!std::isfinite(msg.eta)) return reject("PROGRESS " + msg.part + ": eta is not finite");
  if (msg.num_contour != static_cast<std::int32_t>(msg.contour.size()))
    return reject("PROGRESS " + msg.part + ": num_contour mismatch");
  PartScene& p = scene_.part(msg.part);
  p.has_progress = true;
  p.phase = msg.phase;
  p.eta = msg.eta;
  p.progress_status = msg.status;
  p.contour.clear();
  for (const auto& c : msg.contour) {
    const Eigen::Vector3d v(c[0], c[1], c[2]);
    if (v.allFinite()) p.contour.push_back(v);
  }
  ++scene_.versions.plan;  // the contour is drawn with the plan's overlays
  ++scene_.versions.text;
}

void SceneModel::onSimTruth(const sim_truth_t& msg) {
  std::string why;
  for (const part_truth_t& t : msg.parts) {
    const std::optional<Pose> T = node::fromMsg(t.T_cell_part, &why);
    if (!T) {
      reject("SIM_TRUTH " + t.part + ": " + why);
      continue;
    }
    PartScene& p = scene_.part(t.part);
    p.has_truth = true;
    p.T_cell_part_true = *T;
    p.eta_true = t.eta;
  }
  scene_.has_truth = true;
  // No driver heard, or one that has not read the arm (no controller connection): the simulated one.
  if (!scene_.robot_measured) {
    if (const std::optional<Pose> N = node::fromMsg(msg.T_cell_nozzle, &why)) {
      scene_.has_nozzle = true;
      scene_.T_cell_nozzle = *N;
      scene_.tool = msg.tool;
      ++scene_.versions.nozzle;
    }
  }
  ++scene_.versions.parts;
  ++scene_.versions.text;
}

void SceneModel::onNozzlePlan(const nozzle_plan_t& msg) {
  if (msg.num_waypoints != static_cast<std::int32_t>(msg.waypoints.size()))
    return reject("NOZZLE_PLAN: num_waypoints mismatch");
  std::vector<Eigen::Vector3d> plan;
  for (const waypoint_t& w : msg.waypoints) {
    const Eigen::Vector3d v(w.T_cell_nozzle.position[0], w.T_cell_nozzle.position[1], w.T_cell_nozzle.position[2]);
    if (!v.allFinite()) return reject("NOZZLE_PLAN: waypoint is not finite");
    plan.push_back(v);
  }
  scene_.plan = std::move(plan);
  scene_.plan_id = msg.plan_id;
  scene_.plan_part = msg.part;
  scene_.plan_reason = msg.reason;
  ++scene_.versions.plan;
  ++scene_.versions.text;
}

void SceneModel::onRobotState(const robot_state_t& msg) {
  // A driver that has not read the arm over its current connection has not measured the nozzle
  // (before the first read: the cell's origin): its mode is shown, the nozzle stays where it was
  // last seen.
  std::string why;
  const std::optional<Pose> N = msg.measured ? node::fromMsg(msg.T_cell_nozzle, &why) : std::nullopt;
  if (msg.measured && !N) return reject("ROBOT_STATE: " + why);
  if (scene_.robot_mode != msg.mode) ++scene_.versions.text;
  scene_.robot_mode = msg.mode;
  scene_.robot_measured = msg.measured;
  if (!msg.measured) return;
  scene_.has_nozzle = true;
  scene_.T_cell_nozzle = *N;
  scene_.tool = msg.tool;
  ++scene_.versions.nozzle;
}

const char* phaseName(int phase) {
  switch (phase) {
    case progress_t::PHASE_VACUUM_BURIED:
      return "vacuum (buried)";
    case progress_t::PHASE_VACUUM_TRACKED:
      return "vacuum (tracked)";
    case progress_t::PHASE_AIR_BLAST:
      return "air blast";
    case progress_t::PHASE_DONE:
      return "done";
    default:
      return "-";
  }
}

const char* phaseSlug(int phase) {
  switch (phase) {
    case progress_t::PHASE_VACUUM_BURIED:
      return "buried";
    case progress_t::PHASE_VACUUM_TRACKED:
      return "tracked";
    case progress_t::PHASE_AIR_BLAST:
      return "air-blast";
    case progress_t::PHASE_DONE:
      return "done";
    default:
      return "none";
  }
}

const char* trackStatusName(int status) {
  switch (status) {
    case part_pose_t::WAITING:
      return "waiting";
    case part_pose_t::TRACKING:
      return "tracking";
    case part_pose_t::DEGRADED:
      return "degraded";
    case part_pose_t::LOST:
      return "lost";
    default:
      return "?";
  }
}

namespace {
const char* modeName(int mode) {
  static const char* names[] = {"idle", "following", "holding", "e-stopped", "disconnected", "fault"};
  return mode >= 0 && mode <= 5 ? names[mode] : "-";
}
}  // namespace

std::vector<std::string> statusLines(const Scene& scene) {
  std::vector<std::string> lines;
  char buf[512];
  for (const PartScene& p : scene.parts) {
    std::string line = p.name;
    if (p.has_progress) {
      std::snprintf(buf, sizeof(buf), "  phase %d %s  eta %.2f", p.phase, phaseName(p.phase), p.eta);
      line += buf;
    } else {
      line += "  phase -  eta -";
    }
    if (p.has_estimate) {
      line += std::string("  ") + trackStatusName(p.track_status);
      if (!p.method.empty()) line += " (" + p.method + ")";
      if (!p.track_reason.empty()) line += ": " + p.track_reason;
    } else {
      line += "  no pose";
    }
    if (p.has_truth) {
      std::snprintf(buf, sizeof(buf), "  [true eta %.2f]", p.eta_true);
      line += buf;
    }
    lines.push_back(line);
  }
  std::string cell;
  if (scene.cloud_seq >= 0) {
    std::snprintf(buf, sizeof(buf), "POINTS #%lld: %zu points", static_cast<long long>(scene.cloud_seq),
                  scene.cloud.size());
    cell += buf;
  }
  if (scene.plan_id >= 0) {
    std::string about;
    for (const std::string& s : {scene.plan_reason, scene.plan_part})
      if (!s.empty()) about += s + ", ";
    std::snprintf(buf, sizeof(buf), "%splan %lld (%s%zu waypoints)", cell.empty() ? "" : "   ",
                  static_cast<long long>(scene.plan_id), about.c_str(), scene.plan.size());
    cell += buf;
  }
  if (scene.robot_mode >= 0)
    cell += std::string(cell.empty() ? "" : "   ") + "robot " + modeName(scene.robot_mode) +
            (scene.robot_measured ? "" : " (arm not read)");
  if (!cell.empty()) lines.push_back(cell);
  return lines;
}

}  // namespace depowder::viewer
