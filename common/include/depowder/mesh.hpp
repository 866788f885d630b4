// Triangle meshes: loading (STL ascii/binary, OBJ, PLY ascii/binary), writing
// binary STL, and area-weighted surface sampling with normals.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "depowder/geometry.hpp"

namespace depowder {

struct Mesh {
  std::vector<Eigen::Vector3d> vertices;   ///< metres (after the loader's scale)
  std::vector<Eigen::Vector3i> triangles;  ///< indices into vertices, counter-clockwise = outward
};

/// A mesh file could not be read; the message names the file and what was wrong.
class MeshError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The largest extent, in metres after the scale, that loadMesh accepts.
constexpr double kMaxMeshSize = 10.0;

/// Loads .stl (ascii or binary), .obj or .ply (ascii or binary_little_endian) by extension.
/// Coordinates are multiplied by `scale` (e.g. 0.001 for a mesh in millimetres).
/// Throws MeshError naming the file for a missing, empty, malformed or triangle-free file.
Mesh loadMesh(const std::string& path, double scale = 1.0);

/// Writes a binary STL. Throws MeshError if the file cannot be written.
void saveStl(const Mesh& mesh, const std::string& path);

/// Appends b to a (indices shifted).
void append(Mesh& a, const Mesh& b);

Mesh transformed(const Mesh& mesh, const Pose& T);

/// A closed cylinder about the z axis from z = -length to 0, `segments` facets round, outward
/// wound: a nozzle, its tip disc at the origin and its body along -z.
Mesh cylinderMesh(double radius, double length, int segments);

/// The mesh with the vertices at the same place (to `tolerance` m) merged into one, so that a
/// test of its edges is about its surface, not about how a file or generator indexed it.
Mesh welded(const Mesh& mesh, double tolerance = 1e-9);

/// Why the mesh bounds no solid, or empty if it bounds one: each edge must be in as many
/// triangles one way round as the other (a surface without holes, its triangles wound alike) and,
/// with `manifold`, in exactly one each way (no more than two faces meet at an edge, and no
/// triangle repeats a vertex). Compares
/// vertex indices, so weld a mesh whose triangles do not share them. Names the first edge found
/// wrong by its end points.
std::string closednessProblem(const Mesh& mesh, bool manifold = false);

/// Why the mesh bounds no solid as the simulator needs one, or empty if it does: "not a closed
/// surface: " and closednessProblem's answer once welded, or "wound inward ..." for a closed
/// mesh whose volume is not positive.
std::string solidProblem(const Mesh& mesh);

/// Total surface area, m^2.
double surfaceArea(const Mesh& mesh);

/// Enclosed volume by the divergence theorem, m^3 (meaningful for closed meshes).
double volume(const Mesh& mesh);

Eigen::AlignedBox3d bounds(const Mesh& mesh);

/// Unit outward normal of triangle i (zero for a degenerate triangle).
Eigen::Vector3d triangleNormal(const Mesh& mesh, std::size_t i);

struct SurfaceSamples {
  Cloud points;   ///< on the triangles, mesh frame
  Cloud normals;  ///< unit, outward (the triangle's)
};

/// Area-weighted uniform random samples: about area / spacing^2 points, seeded.
/// Throws MeshError for a mesh with no area.
SurfaceSamples sampleSurface(const Mesh& mesh, double spacing, std::uint32_t seed = 1);

/// Exactly `count` area-weighted samples, seeded.
SurfaceSamples sampleSurfaceCount(const Mesh& mesh, std::size_t count, std::uint32_t seed = 1);

/// A closed mesh around surface samples (a CAD model given as points, such as the authors' P_cad
/// of the pipe): the boundary of the points' `radius` neighbourhood, by surface nets on their
/// distance field sampled every `voxel` (m). A sheet of samples becomes a solid 2 x radius
/// thick; a gap between samples wider than 2 x radius becomes a hole. Outward winding. Throws
/// MeshError for no finite point, radius <= voxel, or a grid past 2^27 samples.
Mesh shellAround(const Cloud& points, double radius, double voxel);

/// Euclidean distance from p to the closest point of the mesh (brute force; tests and tools).
double distanceToMesh(const Mesh& mesh, const Eigen::Vector3d& p);

}  // namespace depowder
