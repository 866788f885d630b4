// A self-contained synthetic depowdering scene for the benchmark and the tracker tests:
// parts buried in a flat powder plane, seen by virtual depth cameras (z-buffer), with
// Gaussian range noise, merged and voxel-downsampled like the camera proxy's POINTS.
// Stand-in until frames recorded from depowder-sim are available.
#pragma once

#include <random>
#include <vector>

#include "depowder/geometry.hpp"
#include "depowder/mesh.hpp"

namespace depowder::tracker::scene {

struct Camera {
  Pose T_cell_camera = Pose::Identity();  ///< x right, y down, z forward
  int width = 320;                        ///< pixels
  int height = 240;                       ///< pixels
  double fov_h_deg = 70;                  ///< deg (L515)
  double fov_v_deg = 55;                  ///< deg
};

struct SceneConfig {
  std::vector<Camera> cameras;         ///< empty: the default cell's two cameras
  Eigen::Vector2d box_xy{0.40, 0.30};  ///< m, interior of the build box (powder extent), centred at the origin
  double noise_sigma = 0.0015;         ///< m, Gaussian noise along each pixel's ray
  double voxel = 0.005;                ///< m, voxel leaf of the merged cloud (camera proxy: 5 mm)
};

/// The two cameras of config/cell.yaml: at (0, -+0.35, 0.75) looking at (0, 0, 0.05).
std::vector<Camera> defaultCameras();

struct Placed {
  const Mesh* mesh = nullptr;  ///< part frame, metres
  Pose T_cell_part = Pose::Identity();
};

/// One merged, voxelled cell-frame cloud of `parts` and the powder plane z = powder_z.
Cloud render(const std::vector<Placed>& parts, double powder_z, const SceneConfig& config, std::mt19937& rng);

/// Powder height that leaves `visibility` (0..1) of the part's height uncovered at this
/// pose: H_max - visibility * (H_max - H_min), the inverse of Eq. 2.
double powderHeightFor(const Mesh& mesh, const Pose& T_cell_part, double visibility);

/// The pose that puts the part's lowest point at z = 0.005 m (on the box floor), at (x, y),
/// with the given roll/pitch/yaw (rad).
Pose restingPose(const Mesh& mesh, double x, double y, double roll, double pitch, double yaw);

}  // namespace depowder::tracker::scene
