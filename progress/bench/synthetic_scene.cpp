#include "synthetic_scene.hpp"

#include <cmath>
#include <limits>

#include "depowder/point_grid.hpp"
#include "depowder/progress/progress.hpp"

namespace depowder::progress::bench {

SyntheticScene::SyntheticScene(const Mesh& mesh, std::vector<DepthCamera> cameras, SceneConfig config)
    : mesh_(mesh), cameras_(std::move(cameras)), config_(config) {
  samples_ = sampleSurface(mesh_, config_.splat_spacing, 99).points;
}

Eigen::AlignedBox3d SyntheticScene::boundsAt(const Pose& T_cell_part) const {
  return bounds(transformed(mesh_, T_cell_part));
}

double SyntheticScene::trueEta(const Pose& T_cell_part, double h) const {
  const Eigen::AlignedBox3d b = boundsAt(T_cell_part);
  return etaFromHeights(h, b.max().z(), b.min().z());
}

Cloud SyntheticScene::render(const Pose& T_cell_part, double h, const std::vector<Cylinder>& others,
                             std::mt19937& rng) const {
  // Everything that could be seen: the part above the powder, the powder plane, the others.
  Cloud world;
  for (const Point& p : samples_) {
    const Point q = T_cell_part * p;
    if (q.z() >= h) world.push_back(q);
  }
  const double s = config_.splat_spacing;
  for (double x = -config_.box_half.x(); x <= config_.box_half.x(); x += s)
    for (double y = -config_.box_half.y(); y <= config_.box_half.y(); y += s) world.emplace_back(x, y, h);
  for (const Cylinder& c : others) {
    const int around = static_cast<int>(2 * M_PI * c.radius / s);
    for (double z = c.z0; z <= c.z1; z += s)
      for (int k = 0; k < around; ++k) {
        const double a = 2 * M_PI * k / around;
        world.emplace_back(c.xy.x() + c.radius * std::cos(a), c.xy.y() + c.radius * std::sin(a), z);
      }
    for (double r = 0; r <= c.radius; r += s)  // the bottom disc
      for (int k = 0; k < std::max(1, static_cast<int>(2 * M_PI * r / s)); ++k) {
        const double a = 2 * M_PI * k / std::max(1, static_cast<int>(2 * M_PI * r / s));
        world.emplace_back(c.xy.x() + r * std::cos(a), c.xy.y() + r * std::sin(a), c.z0);
      }
  }

  // One z-buffer per camera: the nearest splat per pixel, then noise along its ray.
  std::normal_distribution<double> noise(0.0, config_.sigma);
  Cloud seen;
  for (const DepthCamera& cam : cameras_) {
    const Pose T_camera_cell = cam.T_cell_camera.inverse();
    std::vector<float> depth(static_cast<std::size_t>(cam.width) * cam.height, std::numeric_limits<float>::max());
    std::vector<int> index(depth.size(), -1);
    for (std::size_t i = 0; i < world.size(); ++i) {
      const Eigen::Vector3d c = T_camera_cell * world[i];
      if (c.z() <= 0.05) continue;
      const int u = static_cast<int>(std::lround(cam.fx * c.x() / c.z() + cam.cx));
      const int v = static_cast<int>(std::lround(cam.fy * c.y() / c.z() + cam.cy));
      if (u < 0 || v < 0 || u >= cam.width || v >= cam.height) continue;
      const std::size_t px = static_cast<std::size_t>(v) * cam.width + u;
      if (c.z() < depth[px]) depth[px] = static_cast<float>(c.z()), index[px] = static_cast<int>(i);
    }
    const Eigen::Vector3d origin = cam.T_cell_camera.translation();
    for (int i : index)
      if (i >= 0) {
        const Eigen::Vector3d ray = (world[i] - origin).normalized();
        seen.push_back(world[i] + noise(rng) * ray);
      }
  }
  return voxelDownsample(seen, config_.voxel);
}

}  // namespace depowder::progress::bench
