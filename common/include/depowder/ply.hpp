// PLY files by hand, ascii and binary_little_endian: the vertex element's x y z (any numeric
// type, other properties skipped) and, when asked, the face element's vertex_indices as
// triangles. Part meshes (mesh.cpp) and recorded scans (perception's point files) read them.
#pragma once

#include <Eigen/Core>
#include <stdexcept>
#include <string>
#include <vector>

namespace depowder {

/// What is wrong with a PLY file and where ("the data section ends early (in vertex 2 of 3)").
class PlyError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct PlyData {
  std::vector<Eigen::Vector3d> vertices;   ///< as stored (NaN kept: scans mark missing points so)
  std::vector<Eigen::Vector3i> triangles;  ///< faces as fans, indices checked against vertices
};

/// Parses a whole PLY file's bytes. With `faces` false, reading stops after the vertex element
/// (a scan needs nothing more). Throws PlyError; never reads past the end, and allocates no
/// more than the bytes given can fill.
PlyData parsePly(const std::string& bytes, bool faces);

}  // namespace depowder
