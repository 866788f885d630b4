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

  /// Point `index` of the cloud the index was built from.
  const Point& point(int index) const { return points_[index]; }
  std::size_t size() const { return points_.size(); }
  double cellSize() const { return cell_; }

 private:
  Cloud points_;                        ///< copy of the input (original order)
  Cloud sorted_;                        ///< the same points in cell order
  std::vector<std::int32_t> original_;  ///< sorted_[k] is points_[original_[k]]
  std::vector<std::uint32_t> start_;    ///< cell c holds sorted_[start_[c] .. start_[c + 1])
  Eigen::Vector3d origin_ = Eigen::Vector3d::Zero();
  Eigen::Vector3i dims_ = Eigen::Vector3i::Zero();
  double cell_ = 1;
};

}  // namespace depowder::tracker
