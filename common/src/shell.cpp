#include <array>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "depowder/mesh.hpp"
#include "depowder/point_grid.hpp"

namespace depowder {

// Surface nets (Gibson 1998): one vertex in each grid cell the surface crosses, at the mean of
// the crossings on the cell's edges; one quad, of the four cells around it, for each grid edge
// the surface crosses.
Mesh shellAround(const Cloud& points, double radius, double voxel) {
  Cloud finite;
  for (const Point& p : points)
    if (p.allFinite()) finite.push_back(p);
  if (finite.empty()) throw MeshError("shell: no finite point");
  if (!(voxel > 0 && radius > voxel)) throw MeshError("shell: the radius must exceed the voxel, and both be > 0");
  Eigen::AlignedBox3d box;
  for (const Point& p : finite) box.extend(p);
  const Eigen::Vector3d origin = box.min().array() - (radius + 2 * voxel);
  const Eigen::Array3i n = ((box.sizes().array() + 2 * (radius + 2 * voxel)) / voxel).ceil().cast<int>() + 1;
  if (n.cast<double>().prod() > static_cast<double>(1u << 27))
    throw MeshError("shell: " + std::to_string(n.x()) + " x " + std::to_string(n.y()) + " x " + std::to_string(n.z()) +
                    " samples: use a larger voxel");
  auto at = [&](const Eigen::Array3i& s) { return (static_cast<std::size_t>(s.z()) * n.y() + s.y()) * n.x() + s.x(); };
  auto position = [&](const Eigen::Array3i& s) -> Point { return origin + voxel * s.cast<double>().matrix(); };

  // The distance field less the radius: < 0 inside the shell. Beyond radius + 2 voxels it is
  // only known to be positive, which is all a crossing needs.
  const double reach = radius + 2 * voxel;
  const PointGrid grid(finite, reach);
  std::vector<float> f(static_cast<std::size_t>(n.prod()));
  for (int z = 0; z < n.z(); ++z)
    for (int y = 0; y < n.y(); ++y)
      for (int x = 0; x < n.x(); ++x) {
        const PointGrid::Hit hit = grid.nearest(position({x, y, z}), reach);
        f[at({x, y, z})] = static_cast<float>((hit.found() ? std::sqrt(hit.distance2) : reach) - radius);
      }

  // A vertex in each cell whose corners differ in sign.
  Mesh mesh;
  std::vector<int> vertex_of(f.size(), -1);  // by the cell's lowest corner
  // The cell's 12 edges, between its corners k = x + 2y + 4z.
  static constexpr std::array<std::array<int, 2>, 12> kEdges{
      {{0, 1}, {2, 3}, {4, 5}, {6, 7}, {0, 2}, {1, 3}, {4, 6}, {5, 7}, {0, 4}, {1, 5}, {2, 6}, {3, 7}}};
  for (int z = 0; z + 1 < n.z(); ++z)
    for (int y = 0; y + 1 < n.y(); ++y)
      for (int x = 0; x + 1 < n.x(); ++x) {
        std::array<float, 8> c;
        int inside = 0;
        for (int k = 0; k < 8; ++k) inside += (c[k] = f[at({x + (k & 1), y + (k >> 1 & 1), z + (k >> 2)})]) < 0;
        if (inside == 0 || inside == 8) continue;
        Eigen::Vector3d sum = Eigen::Vector3d::Zero();
        int crossings = 0;
        for (const auto& [a, b] : kEdges) {
          if ((c[a] < 0) == (c[b] < 0)) continue;
          const double t = c[a] / (c[a] - c[b]);
          const Eigen::Vector3d pa(a & 1, a >> 1 & 1, a >> 2), pb(b & 1, b >> 1 & 1, b >> 2);
          sum += pa + t * (pb - pa);
          ++crossings;
        }
        vertex_of[at({x, y, z})] = static_cast<int>(mesh.vertices.size());
        mesh.vertices.push_back(position({x, y, z}) + voxel * sum / crossings);
      }

  // A quad for each grid edge the surface crosses, from the four cells around it, turned so that
  // its normal leaves the shell. The edge runs along axis a; b and c follow it cyclically, so the
  // cells at (b, c) offsets (0, 0), (-1, 0), (-1, -1), (0, -1) go round it counter-clockwise seen
  // from +a.
  for (int z = 1; z + 1 < n.z(); ++z)
    for (int y = 1; y + 1 < n.y(); ++y)
      for (int x = 1; x + 1 < n.x(); ++x)
        for (int a = 0; a < 3; ++a) {
          auto unit = [](int k) { return Eigen::Vector3i::Unit(k).array().eval(); };
          const Eigen::Array3i s(x, y, z), t = s + unit(a), db = unit((a + 1) % 3), dc = unit((a + 2) % 3);
          const bool in0 = f[at(s)] < 0, in1 = f[at(t)] < 0;
          if (in0 == in1) continue;
          std::array<int, 4> q;
          const std::array<Eigen::Array3i, 4> cells{s, s - db, s - db - dc, s - dc};
          for (int k = 0; k < 4; ++k) q[k] = vertex_of[at(cells[k])];
          if (!in0) std::swap(q[1], q[3]);  // outside at the lower end: the shell is towards -a
          mesh.triangles.emplace_back(q[0], q[1], q[2]);
          mesh.triangles.emplace_back(q[0], q[2], q[3]);
        }
  return mesh;
}

}  // namespace depowder
