#include "depowder/perception/voxel_grid.hpp"

#include <cmath>
#include <stdexcept>

namespace depowder::perception {

VoxelGrid::VoxelGrid(const Eigen::AlignedBox3d& region, double leaf, std::size_t max_dense_cells) : leaf_(leaf) {
  if (!(leaf > 0) || !std::isfinite(leaf)) throw std::invalid_argument("VoxelGrid: leaf must be positive");
  if (region.isEmpty() || !region.min().allFinite() || !region.max().allFinite())
    throw std::invalid_argument("VoxelGrid: region must be a finite, non-empty box");
  lo_ = (region.min() / leaf).array().floor().cast<int>();
  const Eigen::Vector3i hi = (region.max() / leaf).array().floor().cast<int>();
  dims_ = hi - lo_ + Eigen::Vector3i::Ones();
  const double cells = static_cast<double>(dims_.x()) * dims_.y() * dims_.z();
  if (cells > 0x1p62) throw std::invalid_argument("VoxelGrid: region too large for this leaf");
  if (cells <= static_cast<double>(max_dense_cells)) slot_of_.assign(static_cast<std::size_t>(cells), -1);
  for (int dz = -1; dz <= 1; ++dz)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx)
        if ((dx | dy | dz) != 0)
          neighbour_offsets_.push_back((static_cast<std::ptrdiff_t>(dz) * dims_.y() + dy) * dims_.x() + dx);
}

std::int32_t* VoxelGrid::findSlot(std::uint64_t cell) {
  if (!slot_of_.empty()) return &slot_of_[cell];
  return &slot_map_.try_emplace(cell, -1).first->second;
}

std::int32_t VoxelGrid::slotAt(const Eigen::Vector3i& c) const {
  if ((c.array() < 0).any() || (c.array() >= dims_.array()).any()) return -1;
  const std::uint64_t cell =
      (static_cast<std::uint64_t>(c.z()) * dims_.y() + static_cast<std::uint64_t>(c.y())) * dims_.x() + c.x();
  if (!slot_of_.empty()) return slot_of_[cell];
  const auto it = slot_map_.find(cell);
  return it == slot_map_.end() ? -1 : it->second;
}

void VoxelGrid::add(const Cloud& points) {
  // Voxel coordinates relative to the region's first voxel: floor(p / leaf) - lo. Inside the
  // region they are >= 0, where a truncating conversion is floor (and no libm call).
  const double inv = 1.0 / leaf_;
  const Eigen::Array3d lo = lo_.cast<double>().array();
  const std::uint64_t nx = static_cast<std::uint64_t>(dims_.x()), nxy = nx * static_cast<std::uint64_t>(dims_.y());
  voxels_.reserve(voxels_.size() + points.size() / 4);
  for (const Eigen::Vector3d& p : points) {
    const Eigen::Array3d f = p.array() * inv - lo;
    if (!(f.x() >= 0 && f.y() >= 0 && f.z() >= 0 && f.x() < dims_.x() && f.y() < dims_.y() && f.z() < dims_.z())) {
      ++outside_;  // also NaN
      continue;
    }
    const std::uint64_t cell = static_cast<std::uint64_t>(f.z()) * nxy + static_cast<std::uint64_t>(f.y()) * nx +
                               static_cast<std::uint64_t>(f.x());
    std::int32_t* slot = findSlot(cell);
    if (*slot < 0) {
      *slot = static_cast<std::int32_t>(voxels_.size());
      voxels_.push_back({cell, p, 1});
    } else {
      Voxel& v = voxels_[static_cast<std::size_t>(*slot)];
      v.sum += p;
      ++v.count;
    }
  }
}

VoxelGrid::Result VoxelGrid::extract(int min_neighbours) {
  Result out;
  out.voxels = voxels_.size();
  out.outside = outside_;
  out.points.reserve(voxels_.size());
  const std::uint64_t nx = static_cast<std::uint64_t>(dims_.x()), ny = static_cast<std::uint64_t>(dims_.y());
  for (const Voxel& v : voxels_) {
    if (min_neighbours > 0) {
      const Eigen::Vector3i c(static_cast<int>(v.cell % nx), static_cast<int>((v.cell / nx) % ny),
                              static_cast<int>(v.cell / (nx * ny)));
      int occupied = 0;
      const bool interior = (c.array() >= 1).all() && (c.array() < dims_.array() - 1).all();
      if (interior && !slot_of_.empty()) {
        // Dense table, away from its faces: the 26 neighbours at fixed offsets, no bounds checks.
        const std::int32_t* here = slot_of_.data() + v.cell;
        for (std::size_t k = 0; k < neighbour_offsets_.size() && occupied < min_neighbours; ++k)
          occupied += here[neighbour_offsets_[k]] >= 0;
      } else {
        for (int dz = -1; dz <= 1 && occupied < min_neighbours; ++dz)
          for (int dy = -1; dy <= 1 && occupied < min_neighbours; ++dy)
            for (int dx = -1; dx <= 1 && occupied < min_neighbours; ++dx)
              if ((dx | dy | dz) != 0 && slotAt(c + Eigen::Vector3i(dx, dy, dz)) >= 0) ++occupied;
      }
      if (occupied < min_neighbours) {
        ++out.outliers;
        continue;
      }
    }
    out.points.push_back(v.sum / v.count);
  }
  // Reset only what was touched: the dense table stays allocated for the next frame.
  if (!slot_of_.empty()) {
    for (const Voxel& v : voxels_) slot_of_[v.cell] = -1;
  } else {
    slot_map_.clear();
  }
  voxels_.clear();
  outside_ = 0;
  return out;
}

}  // namespace depowder::perception
