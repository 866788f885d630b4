// A depth camera's extrinsics refined against the build box it looks into: ICP of the
// camera's points to the box's known faces (inner walls, rim, outer walls) and a flat powder
// surface of unknown height. The box is the one object every cell has in view whose
// geometry the cell file already holds, so no target is needed; the powder must be flat
// (before a run) and the camera must see the rim and two walls that meet.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "depowder/geometry.hpp"
#include "depowder/perception/depth.hpp"

namespace depowder::perception {

struct BoxCalibrationConfig {
  double start_gate = 0.05;       ///< m: points farther than this from the box at the first guess are ignored
  double final_gate = 0.006;      ///< m: the gate shrinks to this (about 2 sigma of the L515's noise at 0.8 m)
  int max_iterations = 60;        ///< Gauss-Newton steps at most
  double max_sigma_t = 0.0005;    ///< m: a translation axis the points pin worse than this is a failure
  double max_sigma_r_deg = 0.05;  ///< deg: the same for a rotation axis
  std::size_t min_points = 500;   ///< fewer points on the box than this is a failure
  double min_noise = 0.001;       ///< m: the points' noise taken as at least this when judging what they pin
};

struct BoxCalibration {
  bool ok = false;
  std::string problem;                                ///< when !ok: what was wrong, in a sentence
  Pose T_cell_camera = Pose::Identity();              ///< the refined extrinsics
  double powder_level = 0;                            ///< m, the powder surface's height found with them
  std::size_t points = 0;                             ///< points within the final gate
  double median_before = 0;                           ///< m, median distance to the box of the points within
  double median_after = 0;                            ///< start_gate of it, at the first guess and refined
  Eigen::Vector3d sigma_t = Eigen::Vector3d::Zero();  ///< m, how well the points pin x, y, z (cell axes)
  Eigen::Vector3d sigma_r = Eigen::Vector3d::Zero();  ///< rad, and the turns about them
  int iterations = 0;
};

/// One still camera's frames as one: per pixel, the median of the frames that have a return
/// there (0 where fewer than half do). The depth noise of N frames drops about sqrt(N) times.
/// Every frame must have the first one's size and depth unit (else an empty image).
DepthImage medianDepth(const std::vector<DepthImage>& frames);

/// Adds `image` to one camera's frames for medianDepth. A frame of another size or depth unit than
/// those before (the camera switched mode while they were collected) starts the frames over, so
/// they are all of its newest mode; returns how many were dropped for it.
std::size_t addMedianFrame(std::vector<DepthImage>& frames, DepthImage image);

/// Refines T_cell_camera from `camera_points` (camera frame, e.g. a deprojected depth image)
/// starting at `T_initial`, against a box of interior `box_size` (cell origin at the centre of
/// its floor, z up) with walls `wall` thick. Fails, saying why, when too few points lie on the
/// box or when they leave a direction of the pose unpinned (e.g. no wall across it in view).
BoxCalibration calibrateAgainstBox(const Cloud& camera_points, const Pose& T_initial, const Eigen::Vector3d& box_size,
                                   double wall, const BoxCalibrationConfig& config = {});

}  // namespace depowder::perception
