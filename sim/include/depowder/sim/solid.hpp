// Parts seen from above: vertical lines through a regular grid of xy points cut with a
// mesh's triangles. Gives the top / bottom envelope of a posed part over the powder grid
// (the powder's floor) and, in the part's own frame, a point-in-solid test (nozzle-part
// contact) that works for parts made of overlapping closed shells (winding number).
#pragma once

#include <Eigen/Core>
#include <vector>

#include "depowder/geometry.hpp"
#include "depowder/mesh.hpp"

namespace depowder::sim {

/// nx by ny sample points in the xy plane at (x0 + i dx, y0 + j dy).
struct ColumnGrid {
  double x0 = 0, y0 = 0;  ///< m, the point (0, 0)
  double dx = 0.001, dy = 0.001;
  int nx = 0, ny = 0;
};

/// Highest and lowest z where the mesh (vertices already in the grid's frame) crosses the vertical
/// line of each grid point; -inf / +inf where it crosses none.
void meshEnvelope(const std::vector<Eigen::Vector3d>& vertices, const std::vector<Eigen::Vector3i>& triangles,
                  const ColumnGrid& grid, std::vector<double>& top, std::vector<double>& bottom);

/// A mesh's solid as sorted surface crossings along vertical columns of its own frame.
class PartSolid {
 public:
  PartSolid() = default;
  /// `column`: spacing of the columns, m (the test's resolution across z).
  explicit PartSolid(const Mesh& mesh, double column = 0.001);
  /// True if p (mesh frame) is inside: the winding number of the surface below p along its column is
  /// positive (a downward-facing crossing enters the solid, an upward-facing one leaves it).
  bool contains(const Eigen::Vector3d& p) const;
  const Eigen::AlignedBox3d& bounds() const { return bounds_; }

 private:
  struct Crossing {
    float z;
    int winding;  ///< winding number just above z
  };
  ColumnGrid grid_;
  Eigen::AlignedBox3d bounds_;
  std::vector<std::vector<Crossing>> columns_;
};

}  // namespace depowder::sim
