#include "synthetic.hpp"

#include <cmath>
#include <limits>

namespace depowder::perception::synthetic {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();

bool within(const Rect& r, const Eigen::Vector3d& p) {
  for (int k = 0; k < 3; ++k)
    if (k != r.axis && (p[k] < r.lo[k] || p[k] > r.hi[k])) return false;
  return true;
}

Rect rect(int axis, double value, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  return {axis, value, lo, hi};
}
}  // namespace

double Scene::raycast(const Eigen::Vector3d& o, const Eigen::Vector3d& d) const {
  double best = kInf;
  for (const Rect& r : rects) {
    if (std::abs(d[r.axis]) < 1e-12) continue;
    const double t = (r.value - o[r.axis]) / d[r.axis];
    if (t > 1e-9 && t < best && within(r, o + t * d)) best = t;
  }
  for (const Sphere& s : spheres) {
    const Eigen::Vector3d oc = o - s.centre;
    const double a = d.squaredNorm(), b = oc.dot(d), c = oc.squaredNorm() - s.radius * s.radius;
    const double disc = b * b - a * c;
    if (disc < 0) continue;
    const double t = (-b - std::sqrt(disc)) / a;
    if (t > 1e-9 && t < best) best = t;
  }
  return best;
}

double Scene::distance(const Eigen::Vector3d& p) const {
  double best = kInf;
  for (const Rect& r : rects) {
    Eigen::Vector3d q = p.cwiseMax(r.lo).cwiseMin(r.hi);
    q[r.axis] = r.value;
    best = std::min(best, (p - q).norm());
  }
  for (const Sphere& s : spheres) best = std::min(best, std::abs((p - s.centre).norm() - s.radius));
  return best;
}

Scene boxScene(const Eigen::Vector3d& box_size, double powder_level, std::vector<Sphere> spheres) {
  const double X = 0.5 * box_size.x(), Y = 0.5 * box_size.y(), Z = box_size.z(), w = 0.01, table = -0.02;
  Scene s;
  // Powder surface and the inner wall faces above it.
  s.rects.push_back(rect(2, powder_level, {-X, -Y, 0}, {X, Y, 0}));
  s.rects.push_back(rect(0, -X, {0, -Y, powder_level}, {0, Y, Z}));
  s.rects.push_back(rect(0, X, {0, -Y, powder_level}, {0, Y, Z}));
  s.rects.push_back(rect(1, -Y, {-X, 0, powder_level}, {X, 0, Z}));
  s.rects.push_back(rect(1, Y, {-X, 0, powder_level}, {X, 0, Z}));
  // Outer wall faces, rims, table.
  s.rects.push_back(rect(0, -X - w, {0, -Y - w, table}, {0, Y + w, Z}));
  s.rects.push_back(rect(0, X + w, {0, -Y - w, table}, {0, Y + w, Z}));
  s.rects.push_back(rect(1, -Y - w, {-X - w, 0, table}, {X + w, 0, Z}));
  s.rects.push_back(rect(1, Y + w, {-X - w, 0, table}, {X + w, 0, Z}));
  s.rects.push_back(rect(2, Z, {-X - w, -Y - w, 0}, {-X, Y + w, 0}));
  s.rects.push_back(rect(2, Z, {X, -Y - w, 0}, {X + w, Y + w, 0}));
  s.rects.push_back(rect(2, Z, {-X, -Y - w, 0}, {X, -Y, 0}));
  s.rects.push_back(rect(2, Z, {-X, Y, 0}, {X, Y + w, 0}));
  s.rects.push_back(rect(2, table, {-3, -3, 0}, {3, 3, 0}));
  s.spheres = std::move(spheres);
  return s;
}

PinholeCamera makeCamera(const std::string& name, int width, int height, const Pose& T_cell_camera, double fov_h_deg,
                         double fov_v_deg) {
  PinholeCamera c;
  c.name = name;
  c.width = width;
  c.height = height;
  c.fx = focalLength(width, fov_h_deg);
  c.fy = focalLength(height, fov_v_deg);
  c.cx = 0.5 * (width - 1);
  c.cy = 0.5 * (height - 1);
  c.min_range = 0.25;  // L515
  c.max_range = 9.0;
  c.T_cell_camera = T_cell_camera;
  return c;
}

std::vector<PinholeCamera> defaultRig(int width, int height) {
  return {makeCamera("LEFT", width, height, lookAt({0.0, -0.45, 0.55}, {0.0, 0.0, 0.05})),
          makeCamera("RIGHT", width, height, lookAt({0.0, 0.45, 0.55}, {0.0, 0.0, 0.05}))};
}

DepthImage render(const Scene& scene, const PinholeCamera& camera, std::int64_t utime, double depth_unit,
                  const Noise* noise, std::mt19937* rng) {
  DepthImage image;
  image.utime = utime;
  image.width = camera.width;
  image.height = camera.height;
  image.depth_unit = depth_unit;
  const int w = camera.width, h = camera.height;
  std::vector<double> z(static_cast<std::size_t>(w) * h, 0.0);
  const Eigen::Matrix3d& R = camera.T_cell_camera.linear();
  const Eigen::Vector3d o = camera.T_cell_camera.translation();
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      // A ray with unit z in the camera frame: its parameter is the depth z itself.
      const Eigen::Vector3d d = R * Eigen::Vector3d((u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy, 1.0);
      const double t = scene.raycast(o, d);
      z[static_cast<std::size_t>(v) * w + u] = std::isfinite(t) ? t : 0.0;
    }
  if (noise && rng) {
    std::vector<double> clean = z;
    std::uniform_real_distribution<double> uniform(0.0, 1.0);
    std::normal_distribution<double> gauss(0.0, 1.0);
    for (int v = 0; v < h; ++v)
      for (int u = 0; u < w; ++u) {
        double& d = z[static_cast<std::size_t>(v) * w + u];
        if (d <= 0) continue;
        // Flying pixel: a return mixed with a neighbour across a depth edge.
        if (noise->flying_pixel_prob > 0) {
          double other = 0;
          if (u + 1 < w && std::abs(clean[v * w + u + 1] - d) > 0.02) other = clean[v * w + u + 1];
          if (v + 1 < h && std::abs(clean[(v + 1) * w + u] - d) > 0.02) other = clean[(v + 1) * w + u];
          if (other > 0 && uniform(*rng) < noise->flying_pixel_prob) {
            const double a = uniform(*rng);
            d = a * d + (1 - a) * other;
            continue;
          }
        }
        d += gauss(*rng) * (noise->sigma_base + noise->sigma_per_m * d);
      }
  }
  image.depth.resize(z.size());
  for (std::size_t i = 0; i < z.size(); ++i) {
    const double counts = std::round(z[i] / depth_unit);
    const int u = static_cast<int>(i % static_cast<std::size_t>(w)),
              v = static_cast<int>(i / static_cast<std::size_t>(w));
    const double range = z[i] * Eigen::Vector3d((u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy, 1.0).norm();
    const bool valid = z[i] > 0 && range >= camera.min_range && range <= camera.max_range && counts <= 65535;
    image.depth[i] = valid ? static_cast<std::uint16_t>(counts) : 0;
  }
  return image;
}

}  // namespace depowder::perception::synthetic
