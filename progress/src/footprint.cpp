#include "depowder/progress/footprint.hpp"

#include <algorithm>
#include <cmath>
#include <deque>
#include <limits>
#include <unordered_map>
#include <vector>

namespace depowder::progress {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// Squared Euclidean distance transform of one line (Felzenszwalb and Huttenlocher, 2012):
/// d[q] = min_p (q - p)^2 + f[p]. `v`, `z` are scratch of size n and n + 1.
void distanceTransform1d(const std::vector<double>& f, std::vector<double>& d, std::vector<int>& v,
                         std::vector<double>& z) {
  const int n = static_cast<int>(f.size());
  int k = 0;
  v[0] = 0;
  z[0] = -kInf;
  z[1] = kInf;
  for (int q = 1; q < n; ++q) {
    double s = ((f[q] + double(q) * q) - (f[v[k]] + double(v[k]) * v[k])) / (2.0 * q - 2.0 * v[k]);
    while (s <= z[k]) {
      --k;
      s = ((f[q] + double(q) * q) - (f[v[k]] + double(v[k]) * v[k])) / (2.0 * q - 2.0 * v[k]);
    }
    ++k;
    v[k] = q;
    z[k] = s;
    z[k + 1] = kInf;
  }
  k = 0;
  for (int q = 0; q < n; ++q) {
    while (z[k + 1] < q) ++k;
    d[q] = double(q - v[k]) * (q - v[k]) + f[v[k]];
  }
}

double signedArea(const Polyline2& loop) {
  double a = 0;
  for (std::size_t i = 0, j = loop.size() - 1; i < loop.size(); j = i++)
    a += loop[j].x() * loop[i].y() - loop[i].x() * loop[j].y();
  return 0.5 * a;
}

Polyline2 resample(const Polyline2& loop, double spacing) {
  std::vector<double> s(loop.size() + 1, 0.0);
  for (std::size_t i = 0; i < loop.size(); ++i) s[i + 1] = s[i] + (loop[(i + 1) % loop.size()] - loop[i]).norm();
  const double length = s.back();
  if (!(length > 0)) return {};
  const int n = std::max(8, static_cast<int>(std::lround(length / spacing)));
  Polyline2 out;
  out.reserve(n);
  std::size_t seg = 0;
  for (int k = 0; k < n; ++k) {
    const double target = length * k / n;
    while (seg + 1 < loop.size() && s[seg + 1] < target) ++seg;
    const double len = s[seg + 1] - s[seg];
    const double t = len > 0 ? (target - s[seg]) / len : 0.0;
    out.push_back(loop[seg] + t * (loop[(seg + 1) % loop.size()] - loop[seg]));
  }
  return out;
}

}  // namespace

Footprint::Footprint(const Cloud& cad_in_cell, double cell, double close_radius, double reach) {
  if (cad_in_cell.empty() || !(cell > 0)) return;
  // Project to z = 0, one sample per cell / 4 lattice square: samples stacked along z (walls) collapse,
  // and distances stay within cell / 6 of the exact ones.
  auto flat = std::make_shared<Cloud>();
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(kInf), hi = -lo;
  for (const Point& p : cad_in_cell) {
    lo = lo.cwiseMin(p.head<2>());
    hi = hi.cwiseMax(p.head<2>());
  }
  {
    double fine = 0.25 * cell;
    while ((hi.x() - lo.x()) * (hi.y() - lo.y()) / (fine * fine) > 4e6) fine *= 2;  // a huge "part"
    const long nx = static_cast<long>((hi.x() - lo.x()) / fine) + 1,
               ny = static_cast<long>((hi.y() - lo.y()) / fine) + 1;
    std::vector<char> seen(static_cast<std::size_t>(nx * ny), 0);
    for (const Point& p : cad_in_cell) {
      const long key = static_cast<long>((p.y() - lo.y()) / fine) * nx + static_cast<long>((p.x() - lo.x()) / fine);
      if (!seen[key]) seen[key] = 1, flat->emplace_back(p.x(), p.y(), 0.0);
    }
  }
  flat_ = flat;
  grid_ = PointGrid(*flat_, std::max(2 * cell, reach / 3));

  // Raster with a border wider than `reach`, so the border is outside every iso-line asked for.
  cell_ = cell;
  const double border = std::max(reach, close_radius) + 3 * cell;
  origin_ = lo - Eigen::Vector2d::Constant(border);
  width_ = static_cast<int>(std::ceil((hi.x() - lo.x() + 2 * border) / cell)) + 1;
  height_ = static_cast<int>(std::ceil((hi.y() - lo.y() + 2 * border) / cell)) + 1;
  const std::size_t n = static_cast<std::size_t>(width_) * height_;

  // Squared distance (in cells) to the nearest cell holding a sample: a 2-D EDT, rows then columns.
  constexpr double kFar = 1e20;
  std::vector<double> d2(n, kFar);
  for (const Point& p : *flat_) {
    const int c = cellIndex(p.head<2>());
    if (c >= 0) d2[c] = 0;
  }
  const int m = std::max(width_, height_);
  std::vector<double> f(m), d(m), z(m + 1);
  std::vector<int> v(m);
  for (int y = 0; y < height_; ++y) {
    f.resize(width_);
    d.resize(width_);
    for (int x = 0; x < width_; ++x) f[x] = d2[y * width_ + x];
    distanceTransform1d(f, d, v, z);
    for (int x = 0; x < width_; ++x) d2[y * width_ + x] = d[x];
  }
  for (int x = 0; x < width_; ++x) {
    f.resize(height_);
    d.resize(height_);
    for (int y = 0; y < height_; ++y) f[y] = d2[y * width_ + x];
    distanceTransform1d(f, d, v, z);
    for (int y = 0; y < height_; ++y) d2[y * width_ + x] = d[y];
  }
  field_.resize(n);
  for (std::size_t i = 0; i < n; ++i) field_[i] = static_cast<float>(std::sqrt(d2[i]) * cell);

  // Outside = reachable from the raster border through cells farther than close_radius
  // (4-connected flood fill). Everything else is the filled, grown silhouette.
  outside_.assign(n, 0);
  std::deque<int> queue;
  auto seed = [&](int x, int y) {
    const int i = y * width_ + x;
    if (!outside_[i] && field_[i] > close_radius) {
      outside_[i] = 1;
      queue.push_back(i);
    }
  };
  for (int x = 0; x < width_; ++x) seed(x, 0), seed(x, height_ - 1);
  for (int y = 0; y < height_; ++y) seed(0, y), seed(width_ - 1, y);
  while (!queue.empty()) {
    const int i = queue.front();
    queue.pop_front();
    const int x = i % width_, y = i / width_;
    if (x > 0) seed(x - 1, y);
    if (x + 1 < width_) seed(x + 1, y);
    if (y > 0) seed(x, y - 1);
    if (y + 1 < height_) seed(x, y + 1);
  }
  for (std::size_t i = 0; i < n; ++i)
    if (!outside_[i] && field_[i] > close_radius) field_[i] = -1;  // a filled hole
}

int Footprint::cellIndex(const Point2& p) const {
  const Eigen::Vector2d q = (p - origin_) / cell_;
  const double fx = std::floor(q.x() + 0.5), fy = std::floor(q.y() + 0.5);
  if (!(fx >= 0 && fx < width_ && fy >= 0 && fy < height_)) return -1;  // also NaN
  const int x = static_cast<int>(fx), y = static_cast<int>(fy);
  return y * width_ + x;
}

bool Footprint::outside(const Point2& p) const {
  const int c = cellIndex(p);
  if (c < 0) return false;
  if (outside_[c]) return true;
  if (field_[c] < 0) return false;  // a filled hole
  // A cell of the grown silhouette: p may still lie a little beyond close_radius (the raster is
  // coarser than the exact distance). It is on the outer side if a neighbour cell is outside;
  // the grown silhouette is 2 * close_radius thick, so hole and outside never share a neighbour.
  const int x = c % width_, y = c / width_;
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx) {
      const int nx = x + dx, ny = y + dy;
      if (nx >= 0 && nx < width_ && ny >= 0 && ny < height_ && outside_[ny * width_ + nx]) return true;
    }
  return false;
}

double Footprint::distance(const Point2& p, double radius) const {
  if (!flat_) return kInf;
  const PointGrid::Hit hit = grid_.nearest(Eigen::Vector3d(p.x(), p.y(), 0.0), radius);
  return hit.found() ? std::sqrt(hit.distance2) : kInf;
}

bool Footprint::within(const Point2& p, double radius) const {
  return flat_ && grid_.anyWithin(Eigen::Vector3d(p.x(), p.y(), 0.0), radius);
}

double Footprint::rasterDistance(const Point2& p) const {
  const int c = cellIndex(p);
  return c < 0 ? kInf : field_[c];
}

Polyline2 Footprint::outerContour(double level, double spacing) const {
  if (empty() || !(spacing > 0)) return {};
  // Marching squares over the cell centres; a corner is "in" when its field is <= level.
  auto value = [&](int x, int y) { return static_cast<double>(field_[y * width_ + x]); };
  // Edge keys: horizontal edge from node (x, y) to (x + 1, y) = 2 i, vertical to (x, y + 1) = 2 i + 1.
  auto point = [&](long key) {
    const int i = static_cast<int>(key / 2), x = i % width_, y = i / width_;
    const int x2 = key % 2 ? x : x + 1, y2 = key % 2 ? y + 1 : y;
    const double a = value(x, y), b = value(x2, y2);
    const double t = std::clamp((level - a) / (b - a), 0.0, 1.0);
    return Point2(origin_.x() + cell_ * (x + t * (x2 - x)), origin_.y() + cell_ * (y + t * (y2 - y)));
  };
  std::vector<std::pair<long, long>> segments;
  for (int y = 0; y + 1 < height_; ++y)
    for (int x = 0; x + 1 < width_; ++x) {
      const double v0 = value(x, y), v1 = value(x + 1, y), v2 = value(x + 1, y + 1), v3 = value(x, y + 1);
      const int bits = (v0 <= level) | (v1 <= level) << 1 | (v2 <= level) << 2 | (v3 <= level) << 3;
      if (bits == 0 || bits == 15) continue;
      const long i = static_cast<long>(y) * width_ + x;
      const long e0 = 2 * i, e1 = 2 * (i + 1) + 1, e2 = 2 * (i + width_), e3 = 2 * i + 1;
      const long edge[4] = {e0, e1, e2, e3};
      if (bits == 5 || bits == 10) {  // saddle: decide by the centre value
        const bool centre_in = 0.25 * (v0 + v1 + v2 + v3) <= level;
        if ((bits == 5) == centre_in) {  // corners 0 and 2 joined (or 1 and 3 apart): cut around 1 and 3
          segments.emplace_back(e0, e1);
          segments.emplace_back(e2, e3);
        } else {
          segments.emplace_back(e0, e3);
          segments.emplace_back(e1, e2);
        }
        continue;
      }
      // Edge k joins corners k and k + 1 (mod 4): crossed when their states differ.
      long found[2];
      int count = 0;
      for (int k = 0; k < 4; ++k)
        if (((bits >> k) & 1) != ((bits >> ((k + 1) % 4)) & 1)) found[count++] = edge[k];
      if (count == 2) segments.emplace_back(found[0], found[1]);
    }

  // Chain segments into closed loops through their shared edge keys.
  std::unordered_map<long, std::pair<int, int>> at;
  at.reserve(segments.size() * 2);
  for (int s = 0; s < static_cast<int>(segments.size()); ++s)
    for (long key : {segments[s].first, segments[s].second}) {
      auto [it, inserted] = at.try_emplace(key, s, -1);
      if (!inserted) it->second.second = s;
    }
  std::vector<char> used(segments.size(), 0);
  Polyline2 best;
  double best_area = 0;
  for (int start = 0; start < static_cast<int>(segments.size()); ++start) {
    if (used[start]) continue;
    Polyline2 loop;
    int s = start;
    long key = segments[s].first;
    while (s >= 0 && !used[s]) {
      used[s] = 1;
      loop.push_back(point(key));
      key = segments[s].first == key ? segments[s].second : segments[s].first;
      const auto& pair = at[key];
      s = pair.first == s ? pair.second : pair.first;
    }
    const double area = std::abs(signedArea(loop));
    if (loop.size() >= 3 && area > best_area) {
      best_area = area;
      best = std::move(loop);
    }
  }
  if (best.empty()) return {};
  if (signedArea(best) < 0) std::reverse(best.begin(), best.end());
  return resample(best, spacing);
}

}  // namespace depowder::progress
