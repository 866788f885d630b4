// What the viewer shows, as plain data (no VTK, no LCM): the newest message of
// each kind, already converted to the library types. The LCM handlers only
// overwrite it (frames the renderer has not drawn yet are dropped here, never in
// the cell); the renderer draws whatever it holds when it gets round to it.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "depowder/geometry.hpp"
#include "depowder/mesh.hpp"

namespace depowder {
struct point_cloud_t;
struct part_pose_t;
struct progress_t;
struct sim_truth_t;
struct nozzle_plan_t;
struct robot_state_t;
}  // namespace depowder
namespace depowder::node {
struct CellConfig;
}

namespace depowder::viewer {

/// One part: its CAD model, the tracker's estimate and template, progress and truth.
struct PartScene {
  std::string name;
  std::shared_ptr<const Mesh> mesh;  ///< part frame, metres; null if the cell has no mesh for it

  // PART_POSE (tracker).
  bool has_estimate = false;
  Pose T_cell_part = Pose::Identity();  ///< estimated pose
  std::int8_t track_status = 0;         ///< part_pose_t::WAITING .. LOST
  std::string track_reason;
  std::string method;
  Cloud template_points;  ///< part frame, metres (Alg. 2)
  std::int32_t template_version = -1;
  std::int64_t pose_utime = 0;

  // PROGRESS.
  bool has_progress = false;
  std::int8_t phase = 0;  ///< progress_t::PHASE_*, 0 = not heard yet
  double eta = 0;
  std::int8_t progress_status = 0;
  std::vector<Eigen::Vector3d> contour;  ///< closed polyline, cell frame

  // SIM_TRUTH (evaluation only; shown faint).
  bool has_truth = false;
  Pose T_cell_part_true = Pose::Identity();
  double eta_true = 0;
};

struct Scene {
  Eigen::Vector3d box_size{0.40, 0.30, 0.20};  ///< interior, metres; origin at the floor centre
  std::vector<PartScene> parts;                ///< cell parts first, in cell order; others as heard

  // POINTS.
  Cloud cloud;  ///< cell frame, metres
  std::int64_t cloud_seq = -1;
  std::int64_t cloud_utime = 0;

  // NOZZLE_PLAN.
  std::vector<Eigen::Vector3d> plan;  ///< waypoint positions, cell frame
  std::int64_t plan_id = -1;
  std::string plan_part, plan_reason;

  // ROBOT_STATE, else SIM_TRUTH's nozzle.
  bool has_nozzle = false;
  Pose T_cell_nozzle = Pose::Identity();  ///< z axis = spray direction
  std::int8_t tool = 0;                   ///< waypoint_t::TOOL_*
  std::int8_t robot_mode = -1;            ///< robot_state_t::MODE_*, -1 = no ROBOT_STATE heard
  bool robot_measured = false;            ///< the last ROBOT_STATE's nozzle was read from the arm (false: none heard)
  /// The tool drawn at T_cell_nozzle, in the nozzle frame (tip at the origin, body along -z):
  /// the nozzle tube up to the flange and the end effector on it (sceneFromCell). Null: a
  /// small cylinder marks the tip.
  std::shared_ptr<const Mesh> tool_mesh;

  bool has_truth = false;

  /// Incremented by every change; the renderer redraws what changed since it last looked.
  struct Versions {
    std::uint64_t cloud = 0, parts = 0, templates = 0, plan = 0, nozzle = 0, text = 0;
    std::uint64_t total() const { return cloud + parts + templates + plan + nozzle + text; }
  } versions;

  PartScene* find(const std::string& name);
  const PartScene* find(const std::string& name) const;
  /// The part called `name`, added (without a mesh) if the cell did not list it.
  PartScene& part(const std::string& name);
};

/// Why a message was not taken into the scene (counted by SceneModel).
struct Rejected {
  std::int64_t count = 0;
  std::string last_reason;
};

/// Applies messages to a Scene. Invalid content (NaN or non-unit poses, bad cloud
/// headers) is rejected and counted, never thrown.
class SceneModel {
 public:
  explicit SceneModel(Scene scene = {}) : scene_(std::move(scene)) {}

  void onPoints(const point_cloud_t& msg);
  void onPartPose(const part_pose_t& msg);
  void onProgress(const progress_t& msg);
  void onSimTruth(const sim_truth_t& msg);
  void onNozzlePlan(const nozzle_plan_t& msg);
  void onRobotState(const robot_state_t& msg);

  const Scene& scene() const { return scene_; }
  Scene& scene() { return scene_; }
  const Rejected& rejected() const { return rejected_; }

 private:
  void reject(const std::string& why);
  Scene scene_;
  Rejected rejected_;
};

/// The box, the parts and the tool of a cell, meshes loaded. Throws MeshError naming the file,
/// ConfigError a tool key that cannot be read.
Scene sceneFromCell(const node::CellConfig& cell);

/// The tool as the planner and the driver take it from the cell file (node::readTool): the
/// nozzle tube up its axis from the tip, and the end effector's cylinders from the flange
/// towards the tip, in the nozzle's frame.
Mesh toolOfCell(const node::CellConfig& cell);

/// Short names for the status text.
const char* phaseName(int phase);         ///< "vacuum (buried)", ... "done", "-"
const char* phaseSlug(int phase);         ///< file-name form: "buried", "tracked", "air-blast", "done", "none"
const char* trackStatusName(int status);  ///< "waiting", "tracking", "degraded", "lost", "?"

/// One line of status text per part, e.g. "pipe  phase 2 vacuum (tracked)  eta 0.43  tracking (cu)".
std::vector<std::string> statusLines(const Scene& scene);

}  // namespace depowder::viewer
