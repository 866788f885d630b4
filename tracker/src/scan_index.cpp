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
    cell_of[i] = static_cast<std::uint32_t>((static_cast<std::size_t>(c.z()) * dims_.y() + c.y()) * dims_.x() + c.x());
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

ScanIndex::Hit ScanIndex::nearest(const Point& q, double radius) const {
  Hit hit;
  if (points_.empty() || !q.allFinite() || !(radius > 0)) return hit;
  const Eigen::Array3d rel = (q - origin_).array() / cell_;  // q in cell units
  double best = radius * radius;
  int best_k = -1;
  auto index = [&](int x, int y, int z) { return (static_cast<std::size_t>(z) * dims_.y() + y) * dims_.x() + x; };
  auto scan = [&](std::size_t c) {
    for (std::uint32_t k = start_[c]; k < start_[c + 1]; ++k) {
      const double d2 = (sorted_[k] - q).squaredNorm();
      if (d2 <= best) best = d2, best_k = static_cast<int>(k);
    }
  };
  // The query's own cell first: for a template point on the scan it usually holds the answer,
  // and the search box below then shrinks to the distance found.
  const Eigen::Array3i home = rel.floor().cast<int>();
  const bool home_inside = (home >= 0).all() && (home < dims_.array()).all();
  if (home_inside) scan(index(home.x(), home.y(), home.z()));
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
        scan(index(x, y, z));
      }
    }
  }
  if (best_k >= 0) {
    hit.index = original_[best_k];
    hit.distance2 = best;
  }
  return hit;
}

}  // namespace depowder::tracker
