#include "axis_distance.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace depowder::planner {

namespace {

using V2 = Eigen::Vector2d;

/// Closest point of triangle abc to p (Ericson, Real-Time Collision Detection, 5.1.5).
Point closestOnTriangle(const Point& p, const Point& a, const Point& b, const Point& c) {
  const Point ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Point bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + (d1 / (d1 - d3)) * ab;
  const Point cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + (d2 / (d2 - d6)) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
  const double denom = 1.0 / (va + vb + vc);
  return a + ab * (vb * denom) + ac * (vc * denom);
}

/// The triangle clipped to z0 <= z <= z1 (Sutherland-Hodgman against the two planes).
int clipToSlab(const std::array<Point, 3>& tri, double z0, double z1, std::array<Point, 5>& out) {
  std::array<Point, 5> tmp;
  int n = 0;
  // z >= z0
  for (int i = 0; i < 3; ++i) {
    const Point& p = tri[i];
    const Point& q = tri[(i + 1) % 3];
    const bool pin = p.z() >= z0, qin = q.z() >= z0;
    if (pin) tmp[n++] = p;
    if (pin != qin) tmp[n++] = p + (q - p) * ((z0 - p.z()) / (q.z() - p.z()));
  }
  int m = 0;
  // z <= z1
  for (int i = 0; i < n; ++i) {
    const Point& p = tmp[i];
    const Point& q = tmp[(i + 1) % n];
    const bool pin = p.z() <= z1, qin = q.z() <= z1;
    if (pin) out[m++] = p;
    if (pin != qin && m < 5) out[m++] = p + (q - p) * ((z1 - p.z()) / (q.z() - p.z()));
  }
  return m;
}

/// Nearest point of the convex polygon's xy projection to q (q itself if inside).
V2 closestOnPolygon2(const std::array<Point, 5>& poly, int n, const V2& q) {
  if (n == 1) return poly[0].head<2>();
  bool pos = false, neg = false;
  V2 best = poly[0].head<2>();
  double best_d2 = std::numeric_limits<double>::infinity();
  for (int i = 0; i < n; ++i) {
    const V2 a = poly[i].head<2>(), b = poly[(i + 1) % n].head<2>();
    const V2 ab = b - a;
    const double cr = ab.x() * (q.y() - a.y()) - ab.y() * (q.x() - a.x());
    if (cr > 0) pos = true;
    if (cr < 0) neg = true;
    const double len2 = ab.squaredNorm();
    const double t = len2 > 0 ? std::clamp((q - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
    const V2 c = a + t * ab;
    const double d2 = (c - q).squaredNorm();
    if (d2 < best_d2) {
      best_d2 = d2;
      best = c;
    }
  }
  if (pos != neg && n >= 3) return q;  // strictly on one side of every edge: inside
  return best;
}

}  // namespace

AxisDistanceField::AxisDistanceField(const Mesh& mesh, const Pose& T_cell_part, double cell)
    : t_(mesh.triangles), cell_(cell) {
  v_.reserve(mesh.vertices.size());
  for (const auto& p : mesh.vertices) v_.push_back(T_cell_part * p);
  Eigen::AlignedBox2d all;
  box_.reserve(t_.size());
  for (const auto& t : t_) {
    Eigen::AlignedBox3d b;
    for (int k = 0; k < 3; ++k) b.extend(v_[t[k]]);
    box_.push_back(b);
    all.extend(b.min().head<2>());
    all.extend(b.max().head<2>());
  }
  origin_ = all.min();
  nx_ = std::max(1, static_cast<int>(std::ceil(all.sizes().x() / cell_)) + 1);
  ny_ = std::max(1, static_cast<int>(std::ceil(all.sizes().y() / cell_)) + 1);
  // CSR buckets: each triangle in every cell its xy box touches.
  auto range = [&](const Eigen::AlignedBox3d& b, int& x0, int& x1, int& y0, int& y1) {
    x0 = static_cast<int>((b.min().x() - origin_.x()) / cell_);
    x1 = static_cast<int>((b.max().x() - origin_.x()) / cell_);
    y0 = static_cast<int>((b.min().y() - origin_.y()) / cell_);
    y1 = static_cast<int>((b.max().y() - origin_.y()) / cell_);
  };
  start_.assign(static_cast<std::size_t>(nx_) * ny_ + 1, 0);
  for (const auto& b : box_) {
    int x0, x1, y0, y1;
    range(b, x0, x1, y0, y1);
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) ++start_[static_cast<std::size_t>(y) * nx_ + x + 1];
  }
  for (std::size_t i = 1; i < start_.size(); ++i) start_[i] += start_[i - 1];
  items_.resize(start_.back());
  std::vector<std::uint32_t> fill(start_.begin(), start_.end() - 1);
  for (std::uint32_t i = 0; i < box_.size(); ++i) {
    int x0, x1, y0, y1;
    range(box_[i], x0, x1, y0, y1);
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) items_[fill[static_cast<std::size_t>(y) * nx_ + x]++] = i;
  }
  stamp_.assign(t_.size(), 0);
}

AxisDistanceField::Result AxisDistanceField::query(double x, double y, double z0, double z1, double cutoff) const {
  if (++visit_ == 0) {
    std::fill(stamp_.begin(), stamp_.end(), 0);
    visit_ = 1;
  }
  Result r;
  r.distance = cutoff;
  r.cut_off = true;
  double best2 = cutoff * cutoff;
  const V2 q(x, y);
  const Point tip(x, y, z0), top(x, y, z1);
  const int cx = static_cast<int>(std::floor((x - origin_.x()) / cell_));
  const int cy = static_cast<int>(std::floor((y - origin_.y()) / cell_));
  // Rings of cells around (cx, cy); ring k holds points at least (k - 1) * cell away in xy.
  const int max_ring = std::max({std::abs(cx), std::abs(cy), std::abs(nx_ - 1 - cx), std::abs(ny_ - 1 - cy)}) + 1;
  for (int k = 0; k <= max_ring; ++k) {
    const double ring_min = (k - 1) * cell_;
    if (ring_min > 0 && ring_min * ring_min >= best2) break;
    for (int iy = cy - k; iy <= cy + k; ++iy) {
      if (iy < 0 || iy >= ny_) continue;
      const bool edge_row = iy == cy - k || iy == cy + k;
      for (int ix = cx - k; ix <= cx + k; ix += (edge_row ? 1 : 2 * k)) {
        if (ix >= 0 && ix < nx_) {
          const std::size_t c = static_cast<std::size_t>(iy) * nx_ + ix;
          for (std::uint32_t j = start_[c]; j < start_[c + 1]; ++j) {
            const std::uint32_t ti = items_[j];
            if (stamp_[ti] == visit_) continue;
            stamp_[ti] = visit_;
            // Lower bound from the triangle's box.
            const Eigen::AlignedBox3d& b = box_[ti];
            const double dx = std::max({0.0, b.min().x() - x, x - b.max().x()});
            const double dy = std::max({0.0, b.min().y() - y, y - b.max().y()});
            const double dz = std::max({0.0, b.min().z() - z1, z0 - b.max().z()});
            if (dx * dx + dy * dy + dz * dz >= best2) continue;
            const auto& t = t_[ti];
            const std::array<Point, 3> tri{v_[t[0]], v_[t[1]], v_[t[2]]};
            auto consider = [&](const Point& on_part, const Point& on_axis) {
              const double d2 = (on_part - on_axis).squaredNorm();
              if (d2 < best2) {
                best2 = d2;
                r.on_part = on_part;
                r.on_axis = on_axis;
                r.cut_off = false;
              }
            };
            if (b.max().z() >= z0 && b.min().z() <= z1) {
              std::array<Point, 5> poly;
              const int n = clipToSlab(tri, z0, z1, poly);
              if (n > 0) {
                const V2 c2 = closestOnPolygon2(poly, n, q);
                // Height of that point on the triangle: from its plane (a vertical one: below).
                const Point nrm = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
                double z;
                if (std::abs(nrm.z()) > 1e-12)
                  z = std::clamp(
                      tri[0].z() - (nrm.x() * (c2.x() - tri[0].x()) + nrm.y() * (c2.y() - tri[0].y())) / nrm.z(), z0,
                      z1);
                else {
                  // Vertical triangle: the nearest slab point's height is free within the clipped range.
                  double lo = z1, hi = z0;
                  for (int i = 0; i < n; ++i) {
                    lo = std::min(lo, poly[i].z());
                    hi = std::max(hi, poly[i].z());
                  }
                  z = 0.5 * (lo + hi);
                }
                consider(Point(c2.x(), c2.y(), z), Point(x, y, z));
              }
            }
            if (b.min().z() < z0) consider(closestOnTriangle(tip, tri[0], tri[1], tri[2]), tip);
            if (b.max().z() > z1) consider(closestOnTriangle(top, tri[0], tri[1], tri[2]), top);
          }
        }
      }
    }
  }
  if (!r.cut_off) r.distance = std::sqrt(best2);
  return r;
}

}  // namespace depowder::planner
