#include "depowder/tracker/template.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <unordered_map>
#include <utility>

namespace depowder::tracker {

Indices deriveTemplate(const Cloud& cad_points, const Pose& T_cell_part, const ScanIndex& scan, double xi) {
  Indices out;
  const double xi2 = xi * xi;
  for (std::size_t i = 0; i < cad_points.size(); ++i) {
    // Alg. 2, lines 3-4: nearest scan point and its distance to the CAD point at the current pose.
    const ScanIndex::Hit hit = scan.nearest(T_cell_part * cad_points[i], xi);
    // Lines 5-6: d < xi adds the CAD point to the template.
    if (hit.found() && hit.distance2 < xi2) out.push_back(static_cast<std::uint32_t>(i));
  }
  return out;
}

Indices thinned(const Cloud& cad_points, const Indices& indices, double leaf) {
  if (!(leaf > 0)) return indices;
  // First sample per voxel, then sorted by voxel (z, y, x): consecutive ICP queries then fall
  // in neighbouring grid cells, which keeps the association cache-friendly.
  std::unordered_map<std::uint64_t, std::uint32_t> first;
  first.reserve(indices.size());
  for (const std::uint32_t i : indices) {
    const Eigen::Array3i c = (cad_points[i] / leaf).array().floor().cast<int>();
    const std::uint64_t key = (static_cast<std::uint64_t>((c.z() + 0x100000) & 0x1FFFFF) << 42) |
                              (static_cast<std::uint64_t>((c.y() + 0x100000) & 0x1FFFFF) << 21) |
                              static_cast<std::uint64_t>((c.x() + 0x100000) & 0x1FFFFF);
    first.try_emplace(key, i);
  }
  std::vector<std::pair<std::uint64_t, std::uint32_t>> sorted(first.begin(), first.end());
  std::sort(sorted.begin(), sorted.end());
  Indices out;
  out.reserve(sorted.size());
  for (const auto& kv : sorted) out.push_back(kv.second);
  return out;
}

Indices allIndices(std::size_t n) {
  Indices out(n);
  std::iota(out.begin(), out.end(), 0u);
  return out;
}

std::size_t cropToPart(const Cloud& scan, const Pose& T_cell_part, const Eigen::AlignedBox3d& box_part, double margin,
                       Cloud& out) {
  out.clear();
  const Pose T_part_cell = T_cell_part.inverse(Eigen::Isometry);
  const Eigen::Array3d lo = box_part.min().array() - margin;
  const Eigen::Array3d hi = box_part.max().array() + margin;
  // The grown box's cell-frame bounds (a hair wider): a point outside them is outside the box,
  // and most of the scan is, so most points are refused without being transformed.
  const Eigen::AlignedBox3d near = bounds(Eigen::AlignedBox3d(lo.matrix(), hi.matrix()), T_cell_part);
  const Eigen::Array3d near_lo = near.min().array() - 1e-9, near_hi = near.max().array() + 1e-9;
  std::size_t non_finite = 0;
  for (const Point& p : scan) {
    if (!p.allFinite()) {
      ++non_finite;
      continue;
    }
    if ((p.array() < near_lo).any() || (p.array() > near_hi).any()) continue;
    const Eigen::Array3d q = (T_part_cell * p).array();
    if ((q >= lo).all() && (q <= hi).all()) out.push_back(p);
  }
  return non_finite;
}

PowderHeights::PowderHeights(const Cloud& band, double mean_height, double radius)
    : mean_(mean_height), radius_(radius) {
  Cloud flat;
  for (const Point& b : band)
    if (b.allFinite()) {
      flat.emplace_back(b.x(), b.y(), 0.0);
      heights_.push_back(b.z());
    }
  flat_ = ScanIndex(flat, radius);
}

double PowderHeights::at(const Eigen::Vector2d& xy) const {
  z_.clear();
  flat_.forEachWithin(Point(xy.x(), xy.y(), 0.0), radius_, [&](int i, double) { z_.push_back(heights_[i]); });
  if (z_.size() < 3) return mean_;
  std::nth_element(z_.begin(), z_.begin() + z_.size() / 2, z_.end());
  return z_[z_.size() / 2];
}

void visibleTemplate(const Cloud& points, const Cloud& normals, const Pose& T_cell_part,
                     const std::vector<Point>& viewpoints, const PowderHeights& powder, double margin,
                     const ScanIndex* scan, double cover, Cloud& out_points, Cloud& out_normals) {
  out_points.clear();
  out_normals.clear();
  constexpr double kPlan = 0.004, kDepth = 0.012;  // the column above a point
  const Eigen::Vector3d mid(0, 0, cover + 0.5 * kDepth);
  const double reach = std::hypot(0.5 * kDepth, kPlan);
  auto covered = [&](const Point& p) {
    bool found = false;
    scan->forEachWithin(p + mid, reach, [&](int j, double) {
      const Eigen::Vector3d d = scan->point(j) - p;
      found = found || (d.head<2>().squaredNorm() < kPlan * kPlan && d.z() >= cover && d.z() <= cover + kDepth);
    });
    return found;
  };
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Point p = T_cell_part * points[i];
    const Eigen::Vector3d n = T_cell_part.linear() * normals[i];
    bool faces = viewpoints.empty();
    for (const Point& eye : viewpoints) faces = faces || n.dot(eye - p) > 0;
    if (!faces) continue;
    if (!powder.empty() && p.z() < powder.at(p.head<2>()) + margin) continue;
    if (scan && cover > 0 && facesUp(n) && covered(p)) continue;
    out_points.push_back(points[i]);
    out_normals.push_back(normals[i]);
  }
}

Cloud gather(const Cloud& points, const Indices& indices) {
  Cloud out;
  out.reserve(indices.size());
  for (const std::uint32_t i : indices) out.push_back(points[i]);
  return out;
}

}  // namespace depowder::tracker
