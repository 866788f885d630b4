// Analytic test scenes: a box part sampled on a regular grid, flat powder planes.
#pragma once

#include <cmath>
#include <functional>
#include <random>

#include "depowder/geometry.hpp"

namespace depowder::progress::test {

/// Points on the six faces of the axis-aligned box [lo, hi], on a grid of about `spacing` (edges included).
inline Cloud boxSurface(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, double spacing) {
  Cloud out;
  for (int axis = 0; axis < 3; ++axis) {
    const int u = (axis + 1) % 3, v = (axis + 2) % 3;
    const int nu = static_cast<int>(std::ceil((hi[u] - lo[u]) / spacing));
    const int nv = static_cast<int>(std::ceil((hi[v] - lo[v]) / spacing));
    for (double side : {lo[axis], hi[axis]})
      for (int i = 0; i <= nu; ++i)
        for (int j = 0; j <= nv; ++j) {
          Point p;
          p[axis] = side;
          p[u] = lo[u] + (hi[u] - lo[u]) * i / nu;
          p[v] = lo[v] + (hi[v] - lo[v]) * j / nv;
          out.push_back(p);
        }
  }
  return out;
}

/// A flat powder surface at height h on a grid of `spacing` over [-half, half]^2, without the
/// points for which `hidden(x, y)` is true (under the part). Optional Gaussian z noise, seeded.
inline Cloud powderPlane(double h, double half, double spacing, const std::function<bool(double, double)>& hidden,
                         double sigma = 0, unsigned seed = 7) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, sigma > 0 ? sigma : 1.0);
  Cloud out;
  const int n = static_cast<int>(std::lround(2 * half / spacing));
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= n; ++j) {
      const double x = -half + i * spacing, y = -half + j * spacing;
      if (hidden && hidden(x, y)) continue;
      out.emplace_back(x, y, h + (sigma > 0 ? noise(rng) : 0.0));
    }
  return out;
}

/// 2-D distance from (x, y) to the axis-aligned square |x|, |y| <= half (0 inside).
inline double distanceToSquare(double x, double y, double half) {
  return std::hypot(std::max(std::abs(x) - half, 0.0), std::max(std::abs(y) - half, 0.0));
}

}  // namespace depowder::progress::test
