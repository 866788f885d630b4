// An analytic scene for tests and benchmarks: the build box (powder surface, inner and
// outer walls, rims) on a table, with spheres as parts, rendered into exact depth
// images by ray casting, optionally with L515-like noise and flying pixels.
#pragma once

#include <cstdint>
#include <random>
#include <vector>

#include "depowder/perception/depth.hpp"

namespace depowder::perception::synthetic {

/// An axis-aligned rectangle: plane coordinate[axis] = value, the other two within [lo, hi].
struct Rect {
  int axis = 2;
  double value = 0;
  Eigen::Vector3d lo = Eigen::Vector3d::Zero();  ///< entries on `axis` are ignored
  Eigen::Vector3d hi = Eigen::Vector3d::Zero();
};

struct Sphere {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  double radius = 0.04;
};

struct Scene {
  std::vector<Rect> rects;
  std::vector<Sphere> spheres;

  /// Depth t >= 1e-9 at which o + t d first hits the scene, or +inf.
  double raycast(const Eigen::Vector3d& o, const Eigen::Vector3d& d) const;
  /// Distance from p to the nearest surface of the scene.
  double distance(const Eigen::Vector3d& p) const;
};

/// The build box of interior `box_size` (walls 1 cm thick) filled with powder to
/// `powder_level`, standing on a table 2 cm below the cell origin, with `spheres`.
Scene boxScene(const Eigen::Vector3d& box_size, double powder_level, std::vector<Sphere> spheres);

/// A pinhole camera with the L515's 70 x 55 deg field of view.
PinholeCamera makeCamera(const std::string& name, int width, int height, const Pose& T_cell_camera,
                         double fov_h_deg = 70, double fov_v_deg = 55);

/// The default cell's two cameras (config/cell.yaml) at the given resolution.
std::vector<PinholeCamera> defaultRig(int width, int height);

struct Noise {
  double sigma_base = 0.0010;      ///< m, depth sigma at zero range (cell.yaml default)
  double sigma_per_m = 0.0025;     ///< m per m of range
  double flying_pixel_prob = 0.0;  ///< chance a depth-edge pixel (jump > 2 cm) returns a mixed depth
};

/// Exact depth image (ray cast per pixel centre), quantised to `depth_unit`; no return where
/// nothing is hit or the distance from the camera is out of its range. With `noise`, Gaussian depth noise and
/// flying pixels drawn from `rng`.
DepthImage render(const Scene& scene, const PinholeCamera& camera, std::int64_t utime, double depth_unit = 0.00025,
                  const Noise* noise = nullptr, std::mt19937* rng = nullptr);

}  // namespace depowder::perception::synthetic
