#include "depowder/sim/camera.hpp"

namespace depowder::sim {

CameraModel CameraModel::fromFov(std::string name, int width, int height, double fov_h_deg, double fov_v_deg,
                                 const Pose& T_cell_camera) {
  CameraModel c;
  c.name = std::move(name);
  c.width = width;
  c.height = height;
  c.fx = focalLength(width, fov_h_deg);
  c.fy = focalLength(height, fov_v_deg);
  c.cx = 0.5 * (width - 1);
  c.cy = 0.5 * (height - 1);
  c.T_cell_camera = T_cell_camera;
  return c;
}

Point DepthImage::point(int u, int v) const {
  const double z = metres(u, v);
  return {(u - cx) / fx * z, (v - cy) / fy * z, z};
}

Cloud DepthImage::cellCloud() const {
  Cloud cloud;
  for (int v = 0; v < height; ++v)
    for (int u = 0; u < width; ++u)
      if (depth[static_cast<std::size_t>(v) * width + u] != 0) cloud.push_back(T_cell_camera * point(u, v));
  return cloud;
}

}  // namespace depowder::sim
