// Fixed-radius nearest-neighbour search on a dense voxel grid (CSR layout).
// Built once per frame in O(n); a query with radius <= cell size visits at most
// 2x2x2 cells. This is what ICP association, template update (Alg. 2) and
// segmentation need: "the nearest point, if closer than r".
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "depowder/geometry.hpp"

namespace depowder {

class PointGrid {
 public:
  struct Hit {
    int index = -1;  ///< index into the cloud the grid was built from; -1 if none within range
    double distance2 = 0;
    bool found() const { return index >= 0; }
  };

  PointGrid() = default;
  /// `cell_size` should be >= the largest radius you will query (metres). The grid
  /// grows its cells if the bounds would need more than `max_cells` cells.
  PointGrid(const Cloud& points, double cell_size, std::size_t max_cells = 1u << 23);

  /// Nearest point within `radius` of q (any radius works; small ones are fastest).
  Hit nearest(const Eigen::Vector3d& q, double radius) const;
  /// True if some point lies within `radius` of q: nearest(q, radius).found(), but q's own cell
  /// is searched first and the search stops at the first point in range.
  bool anyWithin(const Eigen::Vector3d& q, double radius) const;

  std::size_t size() const { return points_ ? points_->size() : 0; }
  double cellSize() const { return cell_; }

 private:
  const Cloud* points_ = nullptr;
  Eigen::Vector3d origin_ = Eigen::Vector3d::Zero();
  Eigen::Vector3i dims_ = Eigen::Vector3i::Zero();
  double cell_ = 1;
  std::vector<std::uint32_t> start_;  ///< CSR: cell c holds order_[start_[c] .. start_[c+1])
  std::vector<std::uint32_t> order_;
};

/// Centroid of the points in each occupied voxel of side `leaf` (metres). Deterministic order.
Cloud voxelDownsample(const Cloud& points, double leaf);

}  // namespace depowder
