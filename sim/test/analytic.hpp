// Analytic ray casts for the tests: axis-aligned rectangles (planes, boxes, cubes), independent
// of the meshes and of the rasteriser.
#pragma once

#include <cmath>
#include <limits>
#include <vector>

#include "depowder/sim/camera.hpp"
#include "depowder/sim/world.hpp"

namespace depowder::sim::test {

struct Rect {
  Eigen::Vector3d c;  ///< centre
  int axis;           ///< normal axis
  Eigen::Vector3d h;  ///< half-extents (the normal axis' entry is ignored)
};

/// Smallest t > 0 with o + t d on a rectangle, +inf if none.
inline double castRects(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const std::vector<Rect>& rects) {
  double best = std::numeric_limits<double>::infinity();
  for (const Rect& r : rects) {
    if (std::abs(d[r.axis]) < 1e-15) continue;
    const double t = (r.c[r.axis] - o[r.axis]) / d[r.axis];
    if (!(t > 0) || t >= best) continue;
    const Eigen::Vector3d p = o + t * d;
    bool inside = true;
    for (int a = 0; a < 3; ++a)
      if (a != r.axis && std::abs(p[a] - r.c[a]) > r.h[a]) inside = false;
    if (inside) best = t;
  }
  return best;
}

/// The six faces of an axis-aligned box.
inline void addBox(std::vector<Rect>& rects, const Eigen::AlignedBox3d& b) {
  const Eigen::Vector3d c = b.center(), h = 0.5 * b.sizes();
  for (int a = 0; a < 3; ++a)
    for (int s = -1; s <= 1; s += 2) {
      Eigen::Vector3d fc = c;
      fc[a] += s * h[a];
      rects.push_back({fc, a, h});
    }
}

/// The build box of World (floor, inner and outer walls, rim), as rectangles.
inline std::vector<Rect> boxRects(const BoxGeometry& box) {
  const double X = 0.5 * box.size.x(), Y = 0.5 * box.size.y(), H = box.size.z(), w = box.wall;
  std::vector<Rect> r;
  r.push_back({{0, 0, 0}, 2, {X, Y, 0}});
  r.push_back({{-X, 0, H / 2}, 0, {0, Y, H / 2}});
  r.push_back({{X, 0, H / 2}, 0, {0, Y, H / 2}});
  r.push_back({{0, -Y, H / 2}, 1, {X, 0, H / 2}});
  r.push_back({{0, Y, H / 2}, 1, {X, 0, H / 2}});
  addBox(r, Eigen::AlignedBox3d(Eigen::Vector3d(-X - w, -Y - w, -w), Eigen::Vector3d(-X, Y + w, H)));
  addBox(r, Eigen::AlignedBox3d(Eigen::Vector3d(X, -Y - w, -w), Eigen::Vector3d(X + w, Y + w, H)));
  addBox(r, Eigen::AlignedBox3d(Eigen::Vector3d(-X, -Y - w, -w), Eigen::Vector3d(X, -Y, H)));
  addBox(r, Eigen::AlignedBox3d(Eigen::Vector3d(-X, Y, -w), Eigen::Vector3d(X, Y + w, H)));
  return r;
}

/// Ray of pixel (u, v) in the cell frame, scaled so that t is the depth along the optical axis.
inline Eigen::Vector3d pixelRay(const CameraModel& c, int u, int v) {
  return c.T_cell_camera.linear() * Eigen::Vector3d((u - c.cx) / c.fx, (v - c.cy) / c.fy, 1.0);
}

/// Range / z of pixel (u, v).
inline double rangePerDepth(const CameraModel& c, int u, int v) {
  return Eigen::Vector3d((u - c.cx) / c.fx, (v - c.cy) / c.fy, 1.0).norm();
}

}  // namespace depowder::sim::test
