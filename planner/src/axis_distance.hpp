// Exact distance from a vertical segment (the nozzle axis) to a posed triangle mesh, fast
// enough to call a few hundred times per replan: per triangle it is the smallest of
//  - the 2-D distance from the axis to the part of the triangle inside the axis' z range
//    (projected to xy; for points at the same height the 3-D distance is horizontal),
//  - the 3-D distance from the axis' lower end to the triangle (if it reaches below), and
//  - from its upper end (if it reaches above);
// each is a distance to some point of the segment and the true minimum is one of them.
// Triangles are bucketed in an xy grid and visited ring by ring with bounding-box bounds.
#pragma once

#include <cstdint>
#include <vector>

#include "depowder/geometry.hpp"
#include "depowder/mesh.hpp"

namespace depowder::planner {

class AxisDistanceField {
 public:
  /// `mesh` in the part frame, placed at T_cell_part. `cell`: bucket size, m.
  AxisDistanceField(const Mesh& mesh, const Pose& T_cell_part, double cell = 0.01);

  struct Result {
    double distance = 0;  ///< m; `cutoff` if nothing is nearer than the cutoff
    Point on_part;        ///< nearest point on the mesh (cell frame); unset when cut off
    Point on_axis;        ///< nearest point on the axis
    bool cut_off = false;
  };
  /// Distance from the segment (x, y, z0)-(x, y, z1), z0 <= z1, to the mesh; anything at or
  /// beyond `cutoff` is reported as `cutoff`.
  Result query(double x, double y, double z0, double z1, double cutoff) const;

 private:
  std::vector<Point> v_;                  // posed vertices
  std::vector<Eigen::Vector3i> t_;        // triangles
  std::vector<Eigen::AlignedBox3d> box_;  // per triangle
  Eigen::Vector2d origin_;
  double cell_;
  int nx_ = 0, ny_ = 0;
  std::vector<std::uint32_t> start_, items_;  // CSR buckets
  mutable std::vector<std::uint32_t> stamp_;
  mutable std::uint32_t visit_ = 0;
};

}  // namespace depowder::planner
