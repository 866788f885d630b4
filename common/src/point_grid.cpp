#include "depowder/point_grid.hpp"

#include <algorithm>
#include <cmath>
#include <unordered_map>

namespace depowder {

PointGrid::PointGrid(const Cloud& points, double cell_size, std::size_t max_cells)
    : points_(&points), cell_(cell_size) {
  if (points.empty()) return;
  const Eigen::AlignedBox3d box = bounds(points);
  origin_ = box.min();
  const Eigen::Vector3d extent = box.sizes();
  auto dimsFor = [&](double cell) { return ((extent / cell).array().floor() + 1).cast<int>().matrix().eval(); };
  dims_ = dimsFor(cell_);
  while (static_cast<double>(dims_.x()) * dims_.y() * dims_.z() > static_cast<double>(max_cells)) {
    cell_ *= 1.5;
    dims_ = dimsFor(cell_);
  }
  const std::size_t n_cells = static_cast<std::size_t>(dims_.x()) * dims_.y() * dims_.z();
  std::vector<std::uint32_t> cell_of(points.size());
  start_.assign(n_cells + 1, 0);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3i c = ((points[i] - origin_) / cell_).array().floor().cast<int>().min(dims_.array() - 1);
    cell_of[i] = static_cast<std::uint32_t>((static_cast<std::size_t>(c.z()) * dims_.y() + c.y()) * dims_.x() + c.x());
    ++start_[cell_of[i] + 1];
  }
  for (std::size_t c = 0; c < n_cells; ++c) start_[c + 1] += start_[c];
  order_.resize(points.size());
  std::vector<std::uint32_t> fill(start_.begin(), start_.end() - 1);
  for (std::size_t i = 0; i < points.size(); ++i) order_[fill[cell_of[i]]++] = static_cast<std::uint32_t>(i);
}

PointGrid::Hit PointGrid::nearest(const Eigen::Vector3d& q, double radius) const {
  Hit hit;
  if (!points_ || points_->empty() || !q.allFinite()) return hit;
  const Eigen::Vector3d lo = (q.array() - radius - origin_.array()) / cell_;
  const Eigen::Vector3d hi = (q.array() + radius - origin_.array()) / cell_;
  const Eigen::Vector3i a = lo.array().floor().cast<int>().max(0);
  const Eigen::Vector3i b = hi.array().floor().cast<int>().min(dims_.array() - 1);
  double best = radius * radius;
  for (int z = a.z(); z <= b.z(); ++z)
    for (int y = a.y(); y <= b.y(); ++y) {
      const std::size_t row = (static_cast<std::size_t>(z) * dims_.y() + y) * dims_.x();
      for (int x = a.x(); x <= b.x(); ++x) {
        const std::size_t c = row + x;
        for (std::uint32_t k = start_[c]; k < start_[c + 1]; ++k) {
          const double d2 = ((*points_)[order_[k]] - q).squaredNorm();
          if (d2 <= best) {
            best = d2;
            hit.index = static_cast<int>(order_[k]);
          }
        }
      }
    }
  hit.distance2 = best;
  return hit;
}

bool PointGrid::anyWithin(const Eigen::Vector3d& q, double radius) const {
  if (!points_ || points_->empty() || !q.allFinite()) return false;
  const double r2 = radius * radius;
  auto cellHas = [&](std::size_t c) {
    for (std::uint32_t k = start_[c]; k < start_[c + 1]; ++k)
      if (((*points_)[order_[k]] - q).squaredNorm() <= r2) return true;
    return false;
  };
  const Eigen::Array3d own = ((q - origin_) / cell_).array().floor();
  const bool inside = (own >= 0).all() && (own < dims_.array().cast<double>()).all();
  const std::size_t own_cell =
      inside ? (static_cast<std::size_t>(own.z()) * dims_.y() + static_cast<std::size_t>(own.y())) * dims_.x() +
                   static_cast<std::size_t>(own.x())
             : start_.size();
  if (inside && cellHas(own_cell)) return true;
  const Eigen::Vector3d lo = (q.array() - radius - origin_.array()) / cell_;
  const Eigen::Vector3d hi = (q.array() + radius - origin_.array()) / cell_;
  const Eigen::Vector3i a = lo.array().floor().cast<int>().max(0);
  const Eigen::Vector3i b = hi.array().floor().cast<int>().min(dims_.array() - 1);
  for (int z = a.z(); z <= b.z(); ++z)
    for (int y = a.y(); y <= b.y(); ++y) {
      const std::size_t row = (static_cast<std::size_t>(z) * dims_.y() + y) * dims_.x();
      for (int x = a.x(); x <= b.x(); ++x)
        if (row + x != own_cell && cellHas(row + x)) return true;
    }
  return false;
}

Cloud voxelDownsample(const Cloud& points, double leaf) {
  struct Acc {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    int n = 0;
    std::size_t first = 0;
  };
  std::unordered_map<std::uint64_t, Acc> voxels;
  voxels.reserve(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d& p = points[i];
    if (!p.allFinite()) continue;
    const Eigen::Array3i c = (p / leaf).array().floor().cast<int>();
    // 21 bits a coordinate: +-1M voxels, i.e. +-5 km at 5 mm.
    const std::uint64_t key = (static_cast<std::uint64_t>(c.x() & 0x1FFFFF) << 42) |
                              (static_cast<std::uint64_t>(c.y() & 0x1FFFFF) << 21) |
                              static_cast<std::uint64_t>(c.z() & 0x1FFFFF);
    auto [it, inserted] = voxels.try_emplace(key);
    if (inserted) it->second.first = i;
    it->second.sum += p;
    ++it->second.n;
  }
  std::vector<const Acc*> ordered;
  ordered.reserve(voxels.size());
  for (const auto& kv : voxels) ordered.push_back(&kv.second);
  std::sort(ordered.begin(), ordered.end(), [](const Acc* a, const Acc* b) { return a->first < b->first; });
  Cloud out;
  out.reserve(ordered.size());
  for (const Acc* a : ordered) out.push_back(a->sum / a->n);
  return out;
}

}  // namespace depowder
