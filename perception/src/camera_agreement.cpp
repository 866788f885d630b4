#include "depowder/perception/camera_agreement.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <vector>

namespace depowder::perception {

namespace {

struct Grid {
  double x0, y0, cell;
  int nx, ny;
  int index(const Point& p) const {
    const int i = static_cast<int>(std::floor((p.x() - x0) / cell)),
              j = static_cast<int>(std::floor((p.y() - y0) / cell));
    return i < 0 || j < 0 || i >= nx || j >= ny ? -1 : j * nx + i;
  }
  Eigen::Vector2d centre(int k) const { return {x0 + (k % nx + 0.5) * cell, y0 + (k / nx + 0.5) * cell}; }
};

struct Heights {
  std::vector<double> sum;
  std::vector<int> count;
};

Heights heights(const Cloud& points, const Grid& g) {
  Heights h{std::vector<double>(static_cast<std::size_t>(g.nx * g.ny), 0.0),
            std::vector<int>(static_cast<std::size_t>(g.nx * g.ny), 0)};
  for (const Point& p : points) {
    const int k = g.index(p);
    if (k < 0) continue;
    h.sum[k] += p.z();
    ++h.count[k];
  }
  return h;
}

}  // namespace

Agreement compareHeights(const Cloud& camera, const Cloud& reference, const Eigen::Vector3d& box_size,
                         const AgreementConfig& config) {
  Agreement out;
  const double half_x = 0.5 * box_size.x() - config.wall_margin, half_y = 0.5 * box_size.y() - config.wall_margin;
  if (half_x <= 0 || half_y <= 0 || config.cell <= 0) return out;
  const Grid g{-half_x, -half_y, config.cell, static_cast<int>(2 * half_x / config.cell),
               static_cast<int>(2 * half_y / config.cell)};
  const Heights a = heights(camera, g), b = heights(reference, g);
  std::vector<Eigen::Vector2d> xy;
  std::vector<double> d;
  for (int k = 0; k < g.nx * g.ny; ++k)
    if (a.count[k] >= config.min_points && b.count[k] >= config.min_points) {
      xy.push_back(g.centre(k));
      d.push_back(a.sum[k] / a.count[k] - b.sum[k] / b.count[k]);
    }
  std::vector<bool> keep(d.size(), true);
  Eigen::Vector3d plane = Eigen::Vector3d::Zero();  // d = offset + slope . xy
  for (int round = 0; round < 3; ++round) {
    Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
    Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
    int n = 0;
    for (std::size_t k = 0; k < d.size(); ++k) {
      if (!keep[k]) continue;
      const Eigen::Vector3d row(1.0, xy[k].x(), xy[k].y());
      A += row * row.transpose();
      rhs += d[k] * row;
      ++n;
    }
    if (n < config.min_cells) return out;
    plane = A.ldlt().solve(rhs);
    out.cells = n;
    if (round == 2) break;
    // Cells beyond 3 MADs (scaled to a sigma) of the fit, but never closer than 1 mm, are dropped.
    std::vector<double> r(d.size());
    for (std::size_t k = 0; k < d.size(); ++k)
      r[k] = std::abs(d[k] - plane.dot(Eigen::Vector3d(1, xy[k].x(), xy[k].y())));
    std::vector<double> sorted = r;
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
    const double limit = std::max(0.001, 3 * 1.4826 * sorted[sorted.size() / 2]);
    for (std::size_t k = 0; k < d.size(); ++k) keep[k] = r[k] <= limit;
  }
  out.valid = true;
  out.offset = plane[0];
  out.slope = plane.tail<2>();
  out.tilt_deg = std::atan(out.slope.norm()) * 180 / M_PI;
  return out;
}

}  // namespace depowder::perception
