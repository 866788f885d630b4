// Nearest-neighbour search in one scan, built once per frame (the tracker's association for ICP
// and Alg. 2). A dense grid of cubic cells with the points copied in cell order; a query visits
// its own cell first and then only the cells nearer than the best match so far, so a template
// point lying on the scan touches one or two cells instead of 27.
#pragma once

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
  /// `cell` (m) should be about the largest query radius. Non-finite points are skipped. The
  /// cell grows if the bounds would need more than `max_cells` cells.
  ScanIndex(const Cloud& points, double cell, std::size_t max_cells = 1u << 22);

  /// The nearest point within `radius` (m) of q (exact).
  Hit nearest(const Point& q, double radius) const;
  /// The nearest point within `radius` of q among those for which accept(index) is true.
  template <class Accept>
  Hit nearest(const Point& q, double radius, const Accept& accept) const;
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
        const std::size_t c = (static_cast<std::size_t>(z) * dims_.y() + y) * dims_.x() + x;
        for (std::uint32_t k = start_[c]; k < start_[c + 1]; ++k) visit(k);
      }
}

template <class Accept>
ScanIndex::Hit ScanIndex::nearest(const Point& q, double radius, const Accept& accept) const {
  Hit hit;
  double best = radius * radius;
  visitCells(q, radius, [&](std::uint32_t k) {
    const double d2 = (sorted_[k] - q).squaredNorm();
    if (d2 <= best && accept(original_[k])) best = d2, hit.index = original_[k];
  });
  if (hit.found()) hit.distance2 = best;
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
