// A self-contained synthetic scene for the progress benchmark: one part at a known pose
// buried in a flat powder surface at height h, seen by the cell's depth cameras. True eta
// is exactly Eq. 2 with H_pow = h. Only visible surfaces are returned (a point-splat
// z-buffer per camera), with depth noise along each ray, merged and voxel-downsampled.
// To be replaced by frames of the simulator (sim/) once it exists.
#pragma once

#include <cstdint>
#include <random>
#include <vector>

#include "depowder/geometry.hpp"
#include "depowder/mesh.hpp"

namespace depowder::progress::bench {

struct DepthCamera {
  Pose T_cell_camera = Pose::Identity();  ///< camera frame: x right, y down, z forward
  int width = 320, height = 240;
  double fx = 228, fy = 230, cx = 159.5, cy = 119.5;  ///< pixels
};

/// Something else in view: a vertical cylinder (the nozzle) of `radius` m from z0 to z1 at (x, y).
struct Cylinder {
  Eigen::Vector2d xy = Eigen::Vector2d::Zero();
  double radius = 0.01, z0 = 0, z1 = 0;
};

struct SceneConfig {
  Eigen::Vector2d box_half{0.20, 0.15};  ///< m, powder extent (the box interior)
  double splat_spacing = 0.001;          ///< m between surface samples rendered
  double sigma = 0.0015;                 ///< m, depth noise along the ray
  double voxel = 0.005;                  ///< m, voxel leaf of the merged cloud
};

class SyntheticScene {
 public:
  /// `mesh` in the part frame; the surface is sampled once at `config.splat_spacing`.
  SyntheticScene(const Mesh& mesh, std::vector<DepthCamera> cameras, SceneConfig config = {});

  /// The merged cloud of the part at `T_cell_part` in powder at height `h`, plus `others`.
  Cloud render(const Pose& T_cell_part, double h, const std::vector<Cylinder>& others, std::mt19937& rng) const;

  /// Exact Eq. 2 at this pose and powder height (H_max / H_min from the mesh vertices).
  double trueEta(const Pose& T_cell_part, double h) const;
  Eigen::AlignedBox3d boundsAt(const Pose& T_cell_part) const;

 private:
  Mesh mesh_;
  Cloud samples_;  ///< part frame
  std::vector<DepthCamera> cameras_;
  SceneConfig config_;
};

}  // namespace depowder::progress::bench
