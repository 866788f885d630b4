#include "depowder/tracker/scan_index.hpp"

#include <algorithm>
#include <cmath>

namespace depowder::tracker {

ScanIndex::ScanIndex(const Cloud& points, double cell, std::size_t max_cells) : cell_(cell > 0 ? cell : 1.0) {
  points_.reserve(points.size());
  for (const Point& p : points)
    if (p.allFinite()) points_.push_back(p);
  if (points_.empty()) return;
  Eigen::AlignedBox3d box;
  for (const Point& p : points_) box.extend(p);
  origin_ = box.min();
  auto dimsFor = [&](double c) { return ((box.sizes() / c).array().floor() + 1).cast<int>().matrix().eval(); };
  dims_ = dimsFor(cell_);
  while (static_cast<double>(dims_.x()) * dims_.y() * dims_.z() > static_cast<double>(max_cells)) {
    cell_ *= 1.5;
    dims_ = dimsFor(cell_);
  }
  // Counting sort of the points by cell (CSR).
  const std::size_t n_cells = static_cast<std::size_t>(dims_.x()) * dims_.y() * dims_.z();
  std::vector<std::uint32_t> cell_of(points_.size());
  start_.assign(n_cells + 1, 0);
  for (std::size_t i = 0; i < points_.size(); ++i) {
    const Eigen::Vector3i c = ((points_[i] - origin_) / cell_).array().floor().cast<int>().min(dims_.array() - 1);
    cell_of[i] = static_cast<std::uint32_t>(cellIndex(c.x(), c.y(), c.z()));
    ++start_[cell_of[i] + 1];
  }
  for (std::size_t c = 0; c < n_cells; ++c) start_[c + 1] += start_[c];
  sorted_.resize(points_.size());
  original_.resize(points_.size());
  std::vector<std::uint32_t> fill(start_.begin(), start_.end() - 1);
  for (std::size_t i = 0; i < points_.size(); ++i) {
    const std::uint32_t k = fill[cell_of[i]]++;
    sorted_[k] = points_[i];
    original_[k] = static_cast<std::int32_t>(i);
  }
}

bool ScanIndex::anyInNeighbourCells(const Point& q) const {
  if (points_.empty() || !q.allFinite()) return false;
  const Eigen::Array3i home = ((q - origin_).array() / cell_).floor().cast<int>();
  const Eigen::Array3i a = (home - 1).max(0), b = (home + 1).min(dims_.array() - 1);
  for (int z = a.z(); z <= b.z(); ++z)
    for (int y = a.y(); y <= b.y(); ++y)
      for (int x = a.x(); x <= b.x(); ++x) {
        const std::size_t c = cellIndex(x, y, z);
        if (start_[c + 1] > start_[c]) return true;
      }
  return false;
}

}  // namespace depowder::tracker
