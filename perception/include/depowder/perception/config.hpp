// Settings of the camera proxy (YAML section `perception`, keys mirror the fields).
#pragma once

#include <cstdint>
#include <vector>

#include "depowder/geometry.hpp"
#include "depowder/perception/camera_agreement.hpp"
#include "depowder/tool.hpp"

namespace depowder::perception {

/// How frames of different cameras are grouped into one time step.
struct MergerConfig {
  double match_tolerance = 0.016;  ///< s: frames whose utimes differ by at most this are one time step
                                   ///< (<= half a frame period: 16.7 ms at 30 fps)
  double max_wait = 0.040;         ///< s (wall clock): a time step is published this long after its first frame even if
                                   ///< a camera is missing, so a dead camera never stalls the stream
  double silent_after = 1.0;       ///< s (wall clock) without a frame: camera reported silent and no longer waited for
  double stale_after = 0.5;        ///< s: a camera whose newest utime lags the newest of all cameras by more is
                                   ///< reported stale and no longer waited for (a dead camera becomes stale
                                   ///< before it becomes silent)
};

/// A robot self-filter: scan points on the nozzle are removed before voxelisation. The nozzle
/// seen by the cameras is matched to the part by ICP and to the powder by Eq. 2; with the
/// planner placing the nozzle relative to the tracked pose, an estimate pulled towards it can
/// run away with it. Its pose comes from ROBOT_STATE (the state nearest each time step).
struct SelfFilterConfig {
  double radius = kNozzleRadius;  ///< m, the nozzle body's radius (depowder-camera: planner.nozzle.radius)
  double length = 0.25;           ///< m of body up its axis from the tip (depowder-camera: the planner's, up to
                                  ///< the flange at robot.tool_offset)
  /// The end effector's body: cylinders from the flange towards the tip, placed as the planner
  /// places them (effectorBodies); depowder-camera takes robot.effector's unless the section
  /// gives one.
  std::vector<EffectorSection> effector = vacuumEffector();
  /// Where the flange is: the nozzle tip in the flange frame (depowder-camera: robot.tool_offset).
  Pose T_flange_nozzle = Pose(Eigen::Translation3d(0, 0, 0.25));
  /// m around the body: range noise, the robot state up to 4 ms from the frame (ROBOT_STATE at
  /// 125 Hz). Not more: where the part touches or falls against the nozzle its own points go too
  /// (1 cm cost the toppling pipe its track); < 0: off.
  double margin = 0.006;
  double max_age = 0.1;  ///< s: no robot state within this of a time step's utime: not filtered
};

struct PerceptionConfig {
  double crop_margin = 0.005;      ///< m added to every side of the box interior before cropping; less than the
                                   ///< wall thickness (1 cm), so the outside of the walls is cut away
  double voxel_leaf = 0.005;       ///< m, voxel side of the downsampling grid (tracker's leaf: 5 mm)
  int outlier_min_neighbours = 2;  ///< keep a voxel only if at least this many of its 26 neighbours are occupied
                                   ///< (radius outlier removal at voxel scale); 0 = off. At 5 mm it removes ~90 %
                                   ///< of the flying-pixel voxels and no surface (bench_perception)
  double resolution = 0.0005;      ///< m per count of the quantised point_cloud_t on the wire
  MergerConfig merger;
  SelfFilterConfig self_filter;
  AgreementConfig agreement;  ///< the cameras' powder heights compared, to catch a camera that moved
};

}  // namespace depowder::perception
