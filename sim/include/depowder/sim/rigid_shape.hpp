// A part as a rigid body: its mass properties and a convex decomposition for the physics
// engine's collision shape. Pure geometry (no engine types in the interface).
//
// The decomposition splits the part's *filled* volume (the solid plus the spaces it encloses:
// a tube's bore, a cup's cavity) into boxes, recursively, until the convex hull of the part
// inside each box exceeds the filled volume in it by at most `tolerance`. A tube segment is one
// convex piece (its bore is filled); the pipe's elbow is several, so the pipe rests on its round
// legs and can roll and topple as an L, not as the prism a single hull would make of it.
#pragma once

#include <Eigen/Core>
#include <array>
#include <vector>

#include "depowder/mesh.hpp"
#include "depowder/sim/solid.hpp"

namespace depowder::sim {

struct MassProperties {
  double volume = 0;                                  ///< m^3
  double mass = 0;                                    ///< kg
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();   ///< m, centre of mass, part frame
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();  ///< kg m^2 about the centre of mass, part-frame axes
};

/// Mass properties by voxel counting (voxel centres every `spacing` m tested against the solid, so
/// parts made of overlapping shells count their overlap once), uniform `density` (kg/m^3).
MassProperties massProperties(const PartSolid& solid, double density, double spacing);

/// The part with the spaces it encloses filled: a point is in it if it is in the solid, or lies
/// between the first and last surface crossing of the line through it parallel to any axis.
class FilledSolid {
 public:
  FilledSolid() = default;
  /// `column`: spacing of the lines, m.
  FilledSolid(const Mesh& mesh, const PartSolid& solid, double column = 0.001);
  bool contains(const Eigen::Vector3d& p) const;
  const Eigen::AlignedBox3d& bounds() const { return bounds_; }

 private:
  struct Axis {
    ColumnGrid grid;  ///< over the two other coordinates (u, v) = (axis + 1, axis + 2) mod 3
    std::vector<double> top, bottom;
  };
  PartSolid solid_;
  Eigen::AlignedBox3d bounds_;
  std::array<Axis, 3> axes_;
};

struct DecompositionConfig {
  double voxel = 0.0025;   ///< m, resolution of the filled volume the pieces are measured against
  double tolerance = 0.2;  ///< a piece's hull may exceed the filled volume inside it by this fraction
  int max_pieces = 24;     ///< the worst pieces are split first; this many at most
};

struct ConvexPiece {
  std::vector<Eigen::Vector3d> points;  ///< part frame; their convex hull is the piece
  double hull_volume = 0;               ///< m^3
  double filled_volume = 0;             ///< m^3 of the filled solid inside the piece's box (voxel count)
};

/// Convex pieces whose hulls cover the filled solid (see above). Throws std::invalid_argument for a
/// mesh without volume.
std::vector<ConvexPiece> convexDecomposition(const Mesh& mesh, const FilledSolid& filled,
                                             const DecompositionConfig& config);

/// Volume of the convex hull of `points`, m^3 (0 for fewer than 4 points or a flat set).
double hullVolume(const std::vector<Eigen::Vector3d>& points);

/// The vertices of the convex hull of `points`, each face moved inward by `shrink` m (0: none).
std::vector<Eigen::Vector3d> hullVertices(const std::vector<Eigen::Vector3d>& points, double shrink = 0);

}  // namespace depowder::sim
