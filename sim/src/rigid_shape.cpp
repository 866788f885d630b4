#include "depowder/sim/rigid_shape.hpp"

#include <LinearMath/btConvexHullComputer.h>

#include <algorithm>
#include <cmath>
#include <queue>
#include <stdexcept>

namespace depowder::sim {
namespace {

using Polygon = std::vector<Eigen::Vector3d>;

// Sutherland-Hodgman: the part of `poly` with sign * (p[axis] - value) >= 0.
Polygon clipPlane(const Polygon& poly, int axis, double value, double sign) {
  Polygon out;
  const std::size_t n = poly.size();
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d& a = poly[i];
    const Eigen::Vector3d& b = poly[(i + 1) % n];
    const double da = sign * (a[axis] - value), db = sign * (b[axis] - value);
    if (da >= 0) out.push_back(a);
    if ((da >= 0) != (db >= 0)) out.push_back(a + (b - a) * (da / (da - db)));
  }
  return out;
}

// Voxel grid of the filled solid over the mesh bounds.
struct VoxelGrid {
  Eigen::Vector3d origin;
  double size = 0;
  Eigen::Vector3i n;
  std::vector<std::uint8_t> filled;
  std::size_t index(int i, int j, int k) const { return (static_cast<std::size_t>(k) * n.y() + j) * n.x() + i; }
  Eigen::Vector3d corner(const Eigen::Vector3i& v) const { return origin + size * v.cast<double>(); }
};

struct Piece {
  Eigen::Vector3i lo, hi;          ///< voxel index box [lo, hi) of its filled voxels (where cuts go)
  Eigen::Vector3i box_lo, box_hi;  ///< the region it was clipped to (the pieces partition the grid)
  ConvexPiece shape;
  double excess = 0;  ///< hull volume beyond the tolerated one, m^3
};

class Decomposer {
 public:
  Decomposer(const Mesh& mesh, const FilledSolid& filled, const DecompositionConfig& config)
      : mesh_(mesh), filled_(filled), config_(config) {
    const Eigen::AlignedBox3d b = depowder::bounds(mesh);
    grid_.size = config.voxel;
    grid_.origin = b.min();
    for (int a = 0; a < 3; ++a)
      grid_.n[a] = std::max(1, static_cast<int>(std::ceil((b.max()[a] - b.min()[a]) / config.voxel - 1e-9)));
    grid_.filled.assign(static_cast<std::size_t>(grid_.n.prod()), 0);
    for (int k = 0; k < grid_.n.z(); ++k)
      for (int j = 0; j < grid_.n.y(); ++j)
        for (int i = 0; i < grid_.n.x(); ++i) {
          const Eigen::Vector3d c = grid_.corner({i, j, k}) + Eigen::Vector3d::Constant(0.5 * config.voxel);
          grid_.filled[grid_.index(i, j, k)] = filled.contains(c);
        }
  }

  std::vector<ConvexPiece> run() {
    auto worse = [](const Piece& a, const Piece& b) { return a.excess < b.excess; };
    std::priority_queue<Piece, std::vector<Piece>, decltype(worse)> open(worse);
    std::vector<ConvexPiece> done;
    Piece all;
    if (!make(Eigen::Vector3i::Zero(), grid_.n, all)) throw std::invalid_argument("convexDecomposition: empty part");
    open.push(all);
    while (!open.empty()) {
      Piece p = open.top();
      open.pop();
      Piece a, b;
      const int pieces = static_cast<int>(done.size() + open.size()) + 1;
      if (p.excess <= 0 || pieces >= config_.max_pieces || !split(p, a, b)) {
        done.push_back(std::move(p.shape));
        continue;
      }
      for (Piece* q : {&a, &b})
        if (!q->shape.points.empty()) open.push(std::move(*q));
    }
    return done;
  }

 private:
  // The piece of voxel box [lo, hi): the mesh clipped to the box (so the pieces of a partition keep all
  // of the surface); its cuts are chosen within the extent of its filled voxels. False if it is empty.
  bool make(Eigen::Vector3i lo, Eigen::Vector3i hi, Piece& out) const {
    Eigen::Vector3i flo = hi, fhi = lo;
    int count = 0;
    for (int k = lo.z(); k < hi.z(); ++k)
      for (int j = lo.y(); j < hi.y(); ++j)
        for (int i = lo.x(); i < hi.x(); ++i)
          if (grid_.filled[grid_.index(i, j, k)]) {
            ++count;
            flo = flo.cwiseMin(Eigen::Vector3i(i, j, k));
            fhi = fhi.cwiseMax(Eigen::Vector3i(i + 1, j + 1, k + 1));
          }
    out.shape.points = points(lo, hi);
    if (out.shape.points.empty()) return false;
    out.lo = count > 0 ? flo : lo;
    out.hi = count > 0 ? fhi : hi;
    out.box_lo = lo;
    out.box_hi = hi;
    out.shape.hull_volume = hullVolume(out.shape.points);
    out.shape.filled_volume = count * std::pow(grid_.size, 3);
    // A sliver of surface with no filled voxel is kept as it is (splitting it would not help).
    out.excess = count == 0 ? 0.0 : out.shape.hull_volume - (1 + config_.tolerance) * out.shape.filled_volume;
    return true;
  }

  // The mesh clipped to the box, plus the box corners inside the filled solid: their hull is
  // the hull of (filled solid ∩ box).
  std::vector<Eigen::Vector3d> points(const Eigen::Vector3i& lo, const Eigen::Vector3i& hi) const {
    const Eigen::Vector3d bmin = grid_.corner(lo), bmax = grid_.corner(hi);
    std::vector<Eigen::Vector3d> out;
    for (const auto& t : mesh_.triangles) {
      Polygon poly{mesh_.vertices[t[0]], mesh_.vertices[t[1]], mesh_.vertices[t[2]]};
      bool outside = false;
      for (int a = 0; a < 3 && !outside; ++a) {
        const double lo_a = std::min({poly[0][a], poly[1][a], poly[2][a]});
        const double hi_a = std::max({poly[0][a], poly[1][a], poly[2][a]});
        outside = hi_a < bmin[a] || lo_a > bmax[a];
      }
      if (outside) continue;
      for (int a = 0; a < 3 && !poly.empty(); ++a) {
        poly = clipPlane(poly, a, bmin[a], +1);
        if (!poly.empty()) poly = clipPlane(poly, a, bmax[a], -1);
      }
      out.insert(out.end(), poly.begin(), poly.end());
    }
    for (int c = 0; c < 8; ++c) {
      const Eigen::Vector3d p((c & 1) ? bmax.x() : bmin.x(), (c & 2) ? bmax.y() : bmin.y(),
                              (c & 4) ? bmax.z() : bmin.z());
      if (filled_.contains(p)) out.push_back(p);
    }
    return out;
  }

  // Best of a few cuts (quarter, half, three quarters along each axis) by total hull volume.
  bool split(const Piece& p, Piece& a, Piece& b) const {
    double best = std::numeric_limits<double>::infinity();
    for (int axis = 0; axis < 3; ++axis) {
      const int extent = p.hi[axis] - p.lo[axis];
      if (extent < 2) continue;
      for (int q = 1; q <= 3; ++q) {
        const int cut = p.lo[axis] + std::clamp(extent * q / 4, 1, extent - 1);
        Eigen::Vector3i hi_a = p.box_hi, lo_b = p.box_lo;
        hi_a[axis] = cut;
        lo_b[axis] = cut;
        Piece pa, pb;
        const bool ha = make(p.box_lo, hi_a, pa), hb = make(lo_b, p.box_hi, pb);
        if (!ha && !hb) continue;
        const double cost = (ha ? pa.shape.hull_volume : 0) + (hb ? pb.shape.hull_volume : 0);
        if (cost < best) {
          best = cost;
          a = ha ? pa : Piece{};
          b = hb ? pb : Piece{};
        }
      }
    }
    // A split that does not shrink the hulls is no progress.
    return best < p.shape.hull_volume * (1 - 1e-6);
  }

  const Mesh& mesh_;
  const FilledSolid& filled_;
  DecompositionConfig config_;
  VoxelGrid grid_;
};

// Runs Bullet's hull computer on the points.
bool computeHull(const std::vector<Eigen::Vector3d>& points, double shrink, btConvexHullComputer& hull) {
  if (points.size() < 4) return false;
  std::vector<double> coords;
  coords.reserve(points.size() * 3);
  for (const auto& p : points) coords.insert(coords.end(), {p.x(), p.y(), p.z()});
  hull.compute(coords.data(), 3 * sizeof(double), static_cast<int>(points.size()), shrink, shrink > 0 ? 0.5 : 0.0);
  return hull.vertices.size() >= 4 && hull.faces.size() >= 4;
}

}  // namespace

MassProperties massProperties(const PartSolid& solid, double density, double spacing) {
  const Eigen::AlignedBox3d& b = solid.bounds();
  MassProperties m;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  Eigen::Matrix3d second = Eigen::Matrix3d::Zero();  // sum of p p^T
  long count = 0;
  for (double z = b.min().z() + 0.5 * spacing; z < b.max().z(); z += spacing)
    for (double y = b.min().y() + 0.5 * spacing; y < b.max().y(); y += spacing)
      for (double x = b.min().x() + 0.5 * spacing; x < b.max().x(); x += spacing) {
        const Eigen::Vector3d p(x, y, z);
        if (!solid.contains(p)) continue;
        ++count;
        sum += p;
        second += p * p.transpose();
      }
  if (count == 0) return m;
  const double dv = spacing * spacing * spacing;
  m.volume = count * dv;
  m.mass = density * m.volume;
  m.centre = sum / count;
  // Second moment about the centre, plus each voxel's own (a cube: s^2/12 per axis).
  const Eigen::Matrix3d c =
      second / count - m.centre * m.centre.transpose() + Eigen::Matrix3d::Identity() * (spacing * spacing / 12.0);
  m.inertia = m.mass * (c.trace() * Eigen::Matrix3d::Identity() - c);
  return m;
}

FilledSolid::FilledSolid(const Mesh& mesh, const PartSolid& solid, double column)
    : solid_(solid), bounds_(depowder::bounds(mesh)) {
  for (int a = 0; a < 3; ++a) {
    const int u = (a + 1) % 3, v = (a + 2) % 3;
    std::vector<Eigen::Vector3d> permuted(mesh.vertices.size());
    for (std::size_t i = 0; i < permuted.size(); ++i) {
      const Eigen::Vector3d& p = mesh.vertices[i];
      permuted[i] = {p[u], p[v], p[a]};
    }
    Axis& ax = axes_[a];
    ax.grid.dx = ax.grid.dy = column;
    ax.grid.x0 = bounds_.min()[u] + 0.3183 * column;  // off the round numbers meshes are built on
    ax.grid.y0 = bounds_.min()[v] + 0.2719 * column;
    ax.grid.nx = static_cast<int>(std::floor((bounds_.max()[u] - ax.grid.x0) / column)) + 1;
    ax.grid.ny = static_cast<int>(std::floor((bounds_.max()[v] - ax.grid.y0) / column)) + 1;
    meshEnvelope(permuted, mesh.triangles, ax.grid, ax.top, ax.bottom);
  }
}

bool FilledSolid::contains(const Eigen::Vector3d& p) const {
  if (axes_[0].top.empty() || !bounds_.contains(p)) return false;
  if (solid_.contains(p)) return true;
  for (int a = 0; a < 3; ++a) {
    const Axis& ax = axes_[a];
    const int i = static_cast<int>(std::lround((p[(a + 1) % 3] - ax.grid.x0) / ax.grid.dx));
    const int j = static_cast<int>(std::lround((p[(a + 2) % 3] - ax.grid.y0) / ax.grid.dy));
    if (i < 0 || j < 0 || i >= ax.grid.nx || j >= ax.grid.ny) continue;
    const std::size_t c = static_cast<std::size_t>(j) * ax.grid.nx + i;
    if (p[a] >= ax.bottom[c] && p[a] <= ax.top[c]) return true;
  }
  return false;
}

std::vector<ConvexPiece> convexDecomposition(const Mesh& mesh, const FilledSolid& filled,
                                             const DecompositionConfig& config) {
  if (mesh.triangles.empty() || !(config.voxel > 0))
    throw std::invalid_argument("convexDecomposition: a mesh with triangles and a positive voxel are needed");
  return Decomposer(mesh, filled, config).run();
}

double hullVolume(const std::vector<Eigen::Vector3d>& points) {
  btConvexHullComputer hull;
  if (!computeHull(points, 0, hull)) return 0;
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (int i = 0; i < hull.vertices.size(); ++i)
    c += Eigen::Vector3d(hull.vertices[i].x(), hull.vertices[i].y(), hull.vertices[i].z());
  c /= hull.vertices.size();
  auto vertex = [&](int i) {
    const btVector3& v = hull.vertices[i];
    return Eigen::Vector3d(v.x(), v.y(), v.z());
  };
  double volume = 0;
  for (int f = 0; f < hull.faces.size(); ++f) {
    const btConvexHullComputer::Edge* start = &hull.edges[hull.faces[f]];
    const Eigen::Vector3d a = vertex(start->getSourceVertex());
    for (const btConvexHullComputer::Edge* e = start->getNextEdgeOfFace();
         e->getTargetVertex() != start->getSourceVertex(); e = e->getNextEdgeOfFace())
      volume += (a - c).dot((vertex(e->getSourceVertex()) - c).cross(vertex(e->getTargetVertex()) - c)) / 6.0;
  }
  return std::abs(volume);
}

std::vector<Eigen::Vector3d> hullVertices(const std::vector<Eigen::Vector3d>& points, double shrink) {
  btConvexHullComputer hull;
  std::vector<Eigen::Vector3d> out;
  if (!computeHull(points, shrink, hull)) return out;
  for (int i = 0; i < hull.vertices.size(); ++i)
    out.emplace_back(hull.vertices[i].x(), hull.vertices[i].y(), hull.vertices[i].z());
  return out;
}

}  // namespace depowder::sim
