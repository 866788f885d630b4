// Voxel downsampling over a fixed region (the crop box), filled one camera cloud at
// a time, with optional removal of isolated voxels (radius outlier removal at voxel
// scale: flying pixels between a part's edge and the powder behind it are isolated).
#pragma once

#include <cstddef>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "depowder/geometry.hpp"

namespace depowder::perception {

class VoxelGrid {
 public:
  struct Result {
    Cloud points;              ///< one centroid per kept voxel, in order of first occurrence
    std::size_t voxels = 0;    ///< occupied voxels before outlier removal
    std::size_t outliers = 0;  ///< voxels removed as isolated
    std::size_t outside = 0;   ///< points ignored because they lay outside the region
  };

  /// Voxels of side `leaf` (m) aligned to the cell origin (voxel i spans [i*leaf, (i+1)*leaf)),
  /// as depowder::voxelDownsample's are. A dense slot table covers `region` when it has at
  /// most `max_dense_cells` voxels (4 bytes each); a hash map is used otherwise.
  VoxelGrid(const Eigen::AlignedBox3d& region, double leaf, std::size_t max_dense_cells = std::size_t{1} << 24);

  /// Accumulates points; non-finite ones and ones outside the region are ignored.
  void add(const Cloud& points);

  /// Centroids of the occupied voxels; with min_neighbours > 0 a voxel is kept only if at
  /// least that many of its 26 neighbours are occupied. Empties the grid for the next frame.
  Result extract(int min_neighbours = 0);

  double leaf() const { return leaf_; }
  bool dense() const { return !slot_of_.empty(); }

 private:
  struct Voxel {
    std::uint64_t cell;
    Eigen::Vector3d sum;
    int count;
  };
  std::int32_t* findSlot(std::uint64_t cell);
  std::int32_t slotAt(const Eigen::Vector3i& c) const;

  double leaf_;
  Eigen::Vector3i lo_;                                        ///< voxel index of the region's minimum corner
  Eigen::Vector3i dims_;                                      ///< voxels along x, y, z
  std::vector<std::int32_t> slot_of_;                         ///< dense: cell -> index into voxels_, -1 = empty
  std::unordered_map<std::uint64_t, std::int32_t> slot_map_;  ///< sparse fallback
  std::vector<Voxel> voxels_;
  std::vector<std::ptrdiff_t> neighbour_offsets_;  ///< the 26 neighbours in the dense table
  std::size_t outside_ = 0;
};

}  // namespace depowder::perception
