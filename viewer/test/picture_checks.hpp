// Shared by the viewer's picture tests: where a cell point must appear in a picture
// (a pinhole model of the camera set-up, written out independently of VTK), what
// counts as red / green / ..., and a test cube.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <memory>

#include "depowder/mesh.hpp"
#include "depowder/viewer/renderer.hpp"

namespace depowder::viewer::test {

/// Pixel (u right, v down from the top-left corner) of a cell point, for a camera with a
/// vertical view angle and square pixels, the image centre on the optical axis.
inline Eigen::Vector2d project(const CameraSetup& c, int width, int height, const Eigen::Vector3d& p) {
  const Eigen::Vector3d d = (c.focal_point - c.position).normalized();
  const Eigen::Vector3d right = d.cross(c.view_up).normalized();
  const Eigen::Vector3d up = right.cross(d);
  const Eigen::Vector3d q = p - c.position;
  const double f = 0.5 * height / std::tan(0.5 * c.view_angle_deg * M_PI / 180);
  return {0.5 * width + f * q.dot(right) / q.dot(d), 0.5 * height - f * q.dot(up) / q.dot(d)};
}

inline bool isRed(const std::uint8_t* c) { return c[0] > 100 && c[0] > 2 * c[1] && c[0] > 2 * c[2]; }
inline bool isGreen(const std::uint8_t* c) { return c[1] > 150 && c[1] > 2 * c[0] && c[1] > 2 * c[2]; }
inline bool isOrange(const std::uint8_t* c) { return c[0] > 200 && c[1] > 100 && c[1] < 210 && c[2] < 80; }
inline bool isBlue(const std::uint8_t* c) { return c[2] > 180 && c[2] > c[0] + 80; }
inline bool isCyan(const std::uint8_t* c) { return c[1] > 120 && c[2] > 120 && c[0] < c[1] - 50; }
inline bool isGrey(const std::uint8_t* c, int min_level) {
  return c[0] >= min_level && std::abs(c[0] - c[1]) < 20 && std::abs(c[1] - c[2]) < 25;
}

/// True if any pixel within `r` of `at` satisfies `pred` (lines and points are a few pixels wide).
template <class Pred>
bool anyNear(const Image& img, const Eigen::Vector2d& at, int r, Pred pred) {
  for (int dv = -r; dv <= r; ++dv)
    for (int du = -r; du <= r; ++du) {
      const int u = static_cast<int>(std::lround(at.x())) + du, v = static_cast<int>(std::lround(at.y())) + dv;
      if (u >= 0 && v >= 0 && u < img.width && v < img.height && pred(img.at(u, v))) return true;
    }
  return false;
}

template <class Pred>
int count(const Image& img, Pred pred) {
  int n = 0;
  for (int v = 0; v < img.height; ++v)
    for (int u = 0; u < img.width; ++u) n += pred(img.at(u, v)) ? 1 : 0;
  return n;
}

/// Axis-aligned cube of side `s` centred on the origin, outward counter-clockwise triangles.
inline Mesh cubeMesh(double s) {
  Mesh m;
  for (int i = 0; i < 8; ++i)
    m.vertices.emplace_back(i & 1 ? s / 2 : -s / 2, i & 2 ? s / 2 : -s / 2, i & 4 ? s / 2 : -s / 2);
  const int faces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& f : faces) {
    m.triangles.emplace_back(f[0], f[1], f[2]);
    m.triangles.emplace_back(f[0], f[2], f[3]);
  }
  return m;
}

}  // namespace depowder::viewer::test
