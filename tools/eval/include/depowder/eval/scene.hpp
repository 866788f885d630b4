// What an evaluation runs on: the cell (box, cameras, simulator and camera-proxy settings),
// the part under test, and the frame pipeline of the real cell done in process:
//   World::render (every camera) -> CameraProxy (deproject, crop, merge, voxel) -> P_i.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "depowder/geometry.hpp"
#include "depowder/mesh.hpp"
#include "depowder/perception/camera_proxy.hpp"
#include "depowder/sim/world.hpp"
#include "depowder/tracker/config.hpp"

namespace depowder::eval {

/// The trackers' settings in every experiment: the library's defaults except eta1 = 0 (ICP at
/// every visibility; the paper reports errors at 20 % too).
tracker::TrackerConfig baseTrackerConfig();

struct EvalCell {
  sim::BoxGeometry box;
  std::vector<sim::CameraModel> cameras;
  sim::SimConfig sim;                                    ///< simulator defaults unless the caller changes them
  perception::PerceptionConfig perception;               ///< the camera process's defaults
  double fps = 30;                                       ///< camera frames per simulated second (L515: 30)
  double step_hz = 120;                                  ///< world steps per simulated second (as depowder-sim)
  tracker::TrackerConfig tracker = baseTrackerConfig();  ///< every method starts from this (method, viewpoints set)
};

/// The cell of a cell file (empty: node::defaultCellPath()) as its processes would run it: box,
/// cameras and the sim section as depowder-sim reads them (physics off: runMoving turns it on),
/// the perception section as depowder-camera does, the tracker section (and progress's Eq. 2
/// settings) as depowder-tracker does, with eta1 = 0 (baseTrackerConfig). Throws
/// node::ConfigError naming file, key and range, or MeshError for a part mesh of the file that
/// cannot be read.
EvalCell loadEvalCell(const std::string& path);

struct EvalPart {
  std::string name;
  Mesh mesh;         ///< part frame, metres
  double xi = 0.01;  ///< m, template distance threshold (paper: 1 cm; 0.8 cm propeller and pipe)
};

/// The paper's xi for a default part (Sec. V-A): 0.8 cm for propeller and pipe, 1 cm otherwise.
double paperXi(const std::string& part);

/// A default part by name (parts::byName) with the paper's xi.
EvalPart defaultPart(const std::string& name);

/// Pose of `mesh` upright (as printed) turned by `yaw` about z, its bounding box centred over
/// `xy` with its bottom at `bottom_z` (cell frame).
Pose placePart(const Mesh& mesh, double yaw, const Eigen::Vector2d& xy, double bottom_z);

/// Camera positions (cell frame): the tracker's viewpoints for back-face culling, as the node gives
/// them (from the cell's cameras section: a claimed pose where sim.camera_truth gives one).
std::vector<Point> viewpoints(const std::vector<sim::CameraModel>& cameras);

/// The simulator's frame as the camera proxy takes it (the fields depth_image_t carries).
struct ProxyInput {
  perception::DepthImage image;
  perception::PinholeCamera camera;
};
/// sim::DepthImage -> perception's DepthImage + PinholeCamera; utime = simulated time in us.
ProxyInput toProxyInput(const sim::DepthImage& frame);

/// Renders every camera of a world and runs the camera proxy on the frames: one P_i per call.
class FrameSource {
 public:
  FrameSource(const EvalCell& cell);
  /// P_i at the world's current time (cell frame, cropped, 5 mm voxels, outliers removed). With
  /// `T_cell_nozzle`, the proxy's self-filter removes the nozzle's points, as ROBOT_STATE has it do
  /// in the cell; without, the nozzle stays in the scan (the paper's interference).
  Cloud capture(sim::World& world, const Pose* T_cell_nozzle = nullptr);

 private:
  perception::CameraProxy proxy_;
  std::int64_t max_wait_us_;
};

/// Seed of one trial, mixing the run's seed with the trial's coordinates (splitmix64), so a
/// trial's world and errors do not depend on which other trials ran.
std::uint32_t trialSeed(std::uint32_t seed, std::uint64_t a, std::uint64_t b, std::uint64_t c);

/// Rotation (deg) and translation (cm) error of an estimate against the truth.
struct PoseError {
  double rot_deg = 0;
  double trans_cm = 0;
};
PoseError poseError(const Pose& estimate, const Pose& truth);
/// Angle (deg) between the estimate's and the truth's part z axes.
double tiltError(const Pose& estimate, const Pose& truth);

}  // namespace depowder::eval
