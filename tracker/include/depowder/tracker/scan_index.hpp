// Nearest-neighbour search in one scan, built once per frame (the tracker's association for ICP
// and Alg. 2). A dense grid of cubic cells with the points copied in cell order; a query visits
// its own cell first and then only the cells nearer than the best match so far, so a template
// point lying on the scan touches one or two cells instead of 27.
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include "depowder/geometry.hpp"

namespace depowder::tracker {

class ScanIndex {
 public:
  struct Hit {
    int index = -1;        ///< into the cloud the index was built from; -1 if none within range
    double distance2 = 0;  ///< m^2
    bool found() const { return index >= 0; }
  };

  ScanIndex() = default;
  /// `cell` (m): about the largest query radius or up to a few times it (the answers are the
  /// same, test_scan_index; only the time differs). Non-finite points are skipped. The cell
  /// grows if the bounds would need more than `max_cells` cells.
  ScanIndex(const Cloud& points, double cell, std::size_t max_cells = 1u << 22);

  /// The nearest point within `radius` (m) of q (exact).
  Hit nearest(const Point& q, double radius) const {
    return nearest(q, radius, [](int) { return true; });
  }
  /// The nearest point within `radius` of q among those for which accept(index) is true
  /// (asked only of points nearer than the best so far).
  template <class Accept>
  Hit nearest(const Point& q, double radius, const Accept& accept) const;
  /// Whether q's cell or one of its 26 neighbours holds a point: every point within one cell of q
  /// is found (and some up to two cells away). A cheap test, no distances.
  bool anyInNeighbourCells(const Point& q) const;
  /// Calls f(index, squared distance) for every point within `radius` of q.
  template <class F>
  void forEachWithin(const Point& q, double radius, const F& f) const;

  /// Point `index` of the cloud the index was built from.
  const Point& point(int index) const { return points_[index]; }
  const Cloud& points() const { return points_; }
  std::size_t size() const { return points_.size(); }
  double cellSize() const { return cell_; }

 private:
  /// Calls visit(k) for the points sorted_[k] in the cells within `radius` of q.
  template <class Visit>
  void visitCells(const Point& q, double radius, const Visit& visit) const;
  /// Index of cell (x, y, z) into start_.
  std::size_t cellIndex(int x, int y, int z) const {
    return (static_cast<std::size_t>(z) * dims_.y() + y) * dims_.x() + x;
  }

  Cloud points_;                        ///< copy of the input (original order)
  Cloud sorted_;                        ///< the same points in cell order
  std::vector<std::int32_t> original_;  ///< sorted_[k] is points_[original_[k]]
  std::vector<std::uint32_t> start_;    ///< cell c holds sorted_[start_[c] .. start_[c + 1])
  Eigen::Vector3d origin_ = Eigen::Vector3d::Zero();
  Eigen::Vector3i dims_ = Eigen::Vector3i::Zero();
  double cell_ = 1;
};

template <class Visit>
void ScanIndex::visitCells(const Point& q, double radius, const Visit& visit) const {
  if (points_.empty() || !q.allFinite() || !(radius > 0)) return;
  const Eigen::Array3d rel = (q - origin_).array() / cell_;
  const Eigen::Array3i a = (rel - radius / cell_).floor().cast<int>().max(0);
  const Eigen::Array3i b = (rel + radius / cell_).floor().cast<int>().min(dims_.array() - 1);
  for (int z = a.z(); z <= b.z(); ++z)
    for (int y = a.y(); y <= b.y(); ++y)
      for (int x = a.x(); x <= b.x(); ++x) {
        const std::size_t c = cellIndex(x, y, z);
        for (std::uint32_t k = start_[c]; k < start_[c + 1]; ++k) visit(k);
      }
}

template <class Accept>
ScanIndex::Hit ScanIndex::nearest(const Point& q, double radius, const Accept& accept) const {
  Hit hit;
  if (points_.empty() || !q.allFinite() || !(radius > 0)) return hit;
  const Eigen::Array3d rel = (q - origin_).array() / cell_;  // q in cell units
  double best = radius * radius;
  int best_k = -1;
  auto scan = [&](std::size_t c) {
    for (std::uint32_t k = start_[c]; k < start_[c + 1]; ++k) {
      const double d2 = (sorted_[k] - q).squaredNorm();
      if (d2 <= best && accept(original_[k])) best = d2, best_k = static_cast<int>(k);
    }
  };
  // The query's own cell first: for a template point on the scan it usually holds the answer,
  // and the search box below then shrinks to the distance found.
  const Eigen::Array3i home = rel.floor().cast<int>();
  const bool home_inside = (home >= 0).all() && (home < dims_.array()).all();
  if (home_inside) scan(cellIndex(home.x(), home.y(), home.z()));
  const double reach = std::sqrt(best) / cell_;
  const Eigen::Array3i a = (rel - reach).floor().cast<int>().max(0);
  const Eigen::Array3i b = (rel + reach).floor().cast<int>().min(dims_.array() - 1);
  for (int z = a.z(); z <= b.z(); ++z) {
    const double gz = z > rel.z() ? z - rel.z() : (rel.z() > z + 1 ? rel.z() - (z + 1) : 0.0);
    for (int y = a.y(); y <= b.y(); ++y) {
      const double gy = y > rel.y() ? y - rel.y() : (rel.y() > y + 1 ? rel.y() - (y + 1) : 0.0);
      for (int x = a.x(); x <= b.x(); ++x) {
        if (home_inside && x == home.x() && y == home.y() && z == home.z()) continue;
        const double gx = x > rel.x() ? x - rel.x() : (rel.x() > x + 1 ? rel.x() - (x + 1) : 0.0);
        // Skip a cell whose box is farther than the best match so far.
        if ((gx * gx + gy * gy + gz * gz) * cell_ * cell_ > best) continue;
        scan(cellIndex(x, y, z));
      }
    }
  }
  if (best_k >= 0) {
    hit.index = original_[best_k];
    hit.distance2 = best;
  }
  return hit;
}

template <class F>
void ScanIndex::forEachWithin(const Point& q, double radius, const F& f) const {
  const double r2 = radius * radius;
  visitCells(q, radius, [&](std::uint32_t k) {
    const double d2 = (sorted_[k] - q).squaredNorm();
    if (d2 <= r2) f(original_[k], d2);
  });
}

}  // namespace depowder::tracker
