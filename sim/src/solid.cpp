#include "depowder/sim/solid.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace depowder::sim {
namespace {

// Calls fn(i, j, z, facing_up) (the triangle's normal points up) for every grid point whose vertical line crosses
// triangle abc (not for vertical triangles, which no vertical line crosses in general).
template <class Fn>
void forColumns(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c, const ColumnGrid& g,
                Fn&& fn) {
  const double area = (b.x() - a.x()) * (c.y() - a.y()) - (b.y() - a.y()) * (c.x() - a.x());
  if (std::abs(area) < 1e-18) return;
  const double lo_x = std::min({a.x(), b.x(), c.x()}), hi_x = std::max({a.x(), b.x(), c.x()});
  const double lo_y = std::min({a.y(), b.y(), c.y()}), hi_y = std::max({a.y(), b.y(), c.y()});
  const int i0 = std::max(0, static_cast<int>(std::ceil((lo_x - g.x0) / g.dx)));
  const int i1 = std::min(g.nx - 1, static_cast<int>(std::floor((hi_x - g.x0) / g.dx)));
  const int j0 = std::max(0, static_cast<int>(std::ceil((lo_y - g.y0) / g.dy)));
  const int j1 = std::min(g.ny - 1, static_cast<int>(std::floor((hi_y - g.y0) / g.dy)));
  const double inv = 1.0 / area;
  // A point on an edge shared by two triangles counts for both; for the winding number that is
  // harmless (both crossings face the same way, or one enters where the other leaves).
  const double eps = 1e-12 * std::abs(area);
  for (int j = j0; j <= j1; ++j)
    for (int i = i0; i <= i1; ++i) {
      const double px = g.x0 + i * g.dx, py = g.y0 + j * g.dy;
      const double wa = ((b.x() - px) * (c.y() - py) - (b.y() - py) * (c.x() - px)) * inv;
      const double wb = ((c.x() - px) * (a.y() - py) - (c.y() - py) * (a.x() - px)) * inv;
      const double wc = 1.0 - wa - wb;
      if (wa < -eps || wb < -eps || wc < -eps) continue;
      fn(i, j, wa * a.z() + wb * b.z() + wc * c.z(), area > 0);
    }
}

}  // namespace

void meshEnvelope(const std::vector<Eigen::Vector3d>& vertices, const std::vector<Eigen::Vector3i>& triangles,
                  const ColumnGrid& grid, std::vector<double>& top, std::vector<double>& bottom) {
  const std::size_t n = static_cast<std::size_t>(grid.nx) * grid.ny;
  top.assign(n, -std::numeric_limits<double>::infinity());
  bottom.assign(n, std::numeric_limits<double>::infinity());
  for (const auto& t : triangles)
    forColumns(vertices[t[0]], vertices[t[1]], vertices[t[2]], grid, [&](int i, int j, double z, bool) {
      const std::size_t c = static_cast<std::size_t>(j) * grid.nx + i;
      top[c] = std::max(top[c], z);
      bottom[c] = std::min(bottom[c], z);
    });
}

PartSolid::PartSolid(const Mesh& mesh, double column) {
  bounds_ = depowder::bounds(mesh);
  // Columns offset by an odd fraction of a spacing, so that they rarely pass exactly through
  // the vertices and edges of meshes built on round numbers.
  grid_.dx = grid_.dy = column;
  grid_.x0 = bounds_.min().x() + 0.3183 * column;
  grid_.y0 = bounds_.min().y() + 0.2719 * column;
  grid_.nx = static_cast<int>(std::floor((bounds_.max().x() - grid_.x0) / column)) + 1;
  grid_.ny = static_cast<int>(std::floor((bounds_.max().y() - grid_.y0) / column)) + 1;
  columns_.assign(static_cast<std::size_t>(grid_.nx) * grid_.ny, {});
  for (std::size_t k = 0; k < mesh.triangles.size(); ++k) {
    const auto& t = mesh.triangles[k];
    const Eigen::Vector3d &a = mesh.vertices[t[0]], &b = mesh.vertices[t[1]], &c = mesh.vertices[t[2]];
    forColumns(a, b, c, grid_, [&](int i, int j, double z, bool up) {
      // Going up, a face whose normal points down enters the solid (+1), one pointing up leaves it.
      columns_[static_cast<std::size_t>(j) * grid_.nx + i].push_back({static_cast<float>(z), up ? -1 : +1});
    });
  }
  for (auto& col : columns_) {
    std::sort(col.begin(), col.end(), [](const Crossing& p, const Crossing& q) { return p.z < q.z; });
    int w = 0;
    for (auto& x : col) x.winding = (w += x.winding);
  }
}

bool PartSolid::contains(const Eigen::Vector3d& p) const {
  if (columns_.empty() || !bounds_.contains(p)) return false;
  const int i = static_cast<int>(std::lround((p.x() - grid_.x0) / grid_.dx));
  const int j = static_cast<int>(std::lround((p.y() - grid_.y0) / grid_.dy));
  if (i < 0 || j < 0 || i >= grid_.nx || j >= grid_.ny) return false;
  const auto& col = columns_[static_cast<std::size_t>(j) * grid_.nx + i];
  const float z = static_cast<float>(p.z());
  const auto it = std::upper_bound(col.begin(), col.end(), z, [](float v, const Crossing& x) { return v < x.z; });
  return it != col.begin() && std::prev(it)->winding > 0;
}

}  // namespace depowder::sim
