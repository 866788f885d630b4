#include "scene.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "depowder/point_grid.hpp"

namespace depowder::tracker::scene {

namespace {

struct Intrinsics {
  double fx, fy, cx, cy;
  explicit Intrinsics(const Camera& c)
      : fx(focalLength(c.width, c.fov_h_deg)),
        fy(focalLength(c.height, c.fov_v_deg)),
        cx(0.5 * (c.width - 1)),
        cy(0.5 * (c.height - 1)) {}
};

constexpr double kNear = 0.05;  // m

// Depth (camera z) of every pixel: the powder plane inside the box, then every part's
// triangles rasterised into a z-buffer (perspective-correct depth).
std::vector<double> depthImage(const Camera& cam, const std::vector<Placed>& parts, double powder_z,
                               const Eigen::Vector2d& box_xy) {
  const Intrinsics K(cam);
  const int W = cam.width, H = cam.height;
  std::vector<double> depth(static_cast<std::size_t>(W) * H, std::numeric_limits<double>::infinity());
  const Eigen::Matrix3d R = cam.T_cell_camera.linear();
  const Eigen::Vector3d o = cam.T_cell_camera.translation();
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u) {
      const Eigen::Vector3d d = R * Eigen::Vector3d((u - K.cx) / K.fx, (v - K.cy) / K.fy, 1.0);
      if (std::abs(d.z()) < 1e-12) continue;
      const double s = (powder_z - o.z()) / d.z();  // camera z of the hit, since d has camera z = 1
      if (s <= kNear) continue;
      const Eigen::Vector3d hit = o + s * d;
      if (std::abs(hit.x()) <= 0.5 * box_xy.x() && std::abs(hit.y()) <= 0.5 * box_xy.y())
        depth[static_cast<std::size_t>(v) * W + u] = s;
    }
  const Pose T_camera_cell = cam.T_cell_camera.inverse(Eigen::Isometry);
  for (const Placed& part : parts) {
    const Pose T = T_camera_cell * part.T_cell_part;
    std::vector<Eigen::Vector3d> pc(part.mesh->vertices.size());
    for (std::size_t i = 0; i < pc.size(); ++i) pc[i] = T * part.mesh->vertices[i];
    for (const Eigen::Vector3i& tri : part.mesh->triangles) {
      const Eigen::Vector3d& a = pc[tri[0]];
      const Eigen::Vector3d& b = pc[tri[1]];
      const Eigen::Vector3d& c = pc[tri[2]];
      if (a.z() <= kNear || b.z() <= kNear || c.z() <= kNear) continue;
      const Eigen::Vector2d pa(K.fx * a.x() / a.z() + K.cx, K.fy * a.y() / a.z() + K.cy);
      const Eigen::Vector2d pb(K.fx * b.x() / b.z() + K.cx, K.fy * b.y() / b.z() + K.cy);
      const Eigen::Vector2d pcc(K.fx * c.x() / c.z() + K.cx, K.fy * c.y() / c.z() + K.cy);
      const double area = (pb - pa).x() * (pcc - pa).y() - (pb - pa).y() * (pcc - pa).x();
      if (std::abs(area) < 1e-12) continue;
      const int u0 = std::max(0, static_cast<int>(std::ceil(std::min({pa.x(), pb.x(), pcc.x()}))));
      const int u1 = std::min(W - 1, static_cast<int>(std::floor(std::max({pa.x(), pb.x(), pcc.x()}))));
      const int v0 = std::max(0, static_cast<int>(std::ceil(std::min({pa.y(), pb.y(), pcc.y()}))));
      const int v1 = std::min(H - 1, static_cast<int>(std::floor(std::max({pa.y(), pb.y(), pcc.y()}))));
      for (int v = v0; v <= v1; ++v)
        for (int u = u0; u <= u1; ++u) {
          const Eigen::Vector2d p(u, v);
          // Barycentric weights from signed areas.
          const double w0 = ((pb - p).x() * (pcc - p).y() - (pb - p).y() * (pcc - p).x()) / area;
          const double w1 = ((pcc - p).x() * (pa - p).y() - (pcc - p).y() * (pa - p).x()) / area;
          const double w2 = 1.0 - w0 - w1;
          if (w0 < 0 || w1 < 0 || w2 < 0) continue;
          const double z = 1.0 / (w0 / a.z() + w1 / b.z() + w2 / c.z());
          double& dst = depth[static_cast<std::size_t>(v) * W + u];
          if (z < dst) dst = z;
        }
    }
  }
  return depth;
}

}  // namespace

std::vector<Camera> defaultCameras() {
  Camera left, right;
  left.T_cell_camera = lookAt({0.0, -0.35, 0.75}, {0.0, 0.0, 0.05});
  right.T_cell_camera = lookAt({0.0, 0.35, 0.75}, {0.0, 0.0, 0.05});
  return {left, right};
}

Cloud render(const std::vector<Placed>& parts, double powder_z, const SceneConfig& config, std::mt19937& rng) {
  const std::vector<Camera> cameras = config.cameras.empty() ? defaultCameras() : config.cameras;
  std::normal_distribution<double> noise(0.0, config.noise_sigma);
  Cloud merged;
  for (const Camera& cam : cameras) {
    const Intrinsics K(cam);
    const std::vector<double> depth = depthImage(cam, parts, powder_z, config.box_xy);
    for (int v = 0; v < cam.height; ++v)
      for (int u = 0; u < cam.width; ++u) {
        const double z = depth[static_cast<std::size_t>(v) * cam.width + u];
        if (!std::isfinite(z)) continue;
        const Eigen::Vector3d ray((u - K.cx) / K.fx, (v - K.cy) / K.fy, 1.0);
        const double range = z * ray.norm() + (config.noise_sigma > 0 ? noise(rng) : 0.0);
        merged.push_back(cam.T_cell_camera * (ray.normalized() * range));
      }
  }
  return voxelDownsample(merged, config.voxel);
}

double powderHeightFor(const Mesh& mesh, const Pose& T_cell_part, double visibility) {
  const Eigen::AlignedBox3d box = bounds(depowder::transformed(mesh, T_cell_part));
  return box.max().z() - visibility * (box.max().z() - box.min().z());
}

Pose restingPose(const Mesh& mesh, double x, double y, double roll, double pitch, double yaw) {
  Pose T = makePoseRpy({x, y, 0.0}, roll, pitch, yaw);
  const Eigen::AlignedBox3d box = bounds(depowder::transformed(mesh, T));
  T.translation().z() = 0.005 - box.min().z();
  return T;
}

}  // namespace depowder::tracker::scene
