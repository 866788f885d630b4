// Part meshes from the user (loadMesh, by extension): a malformed file is a MeshError, never a
// crash, and a mesh that loads has every triangle index inside its vertices; welding keeps its
// triangles and never adds a vertex, and the simulator's closedness test answers. The first byte
// picks the format (and whether the test asks for a manifold); the rest is the file.
#include <cstdlib>

#include "depowder/mesh.hpp"
#include "fuzz.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  static const char* const kExtensions[] = {".stl", ".obj", ".ply"};
  const depowder::fuzz::TempFile file(data + 1, size - 1, kExtensions[data[0] % 3]);
  try {
    const depowder::Mesh mesh = depowder::loadMesh(file.path());
    for (const Eigen::Vector3i& t : mesh.triangles)
      if (t.minCoeff() < 0 || t.maxCoeff() >= static_cast<int>(mesh.vertices.size())) std::abort();
    const depowder::Mesh one = depowder::welded(mesh);
    if (one.triangles.size() != mesh.triangles.size() || one.vertices.size() > mesh.vertices.size()) std::abort();
    for (const Eigen::Vector3i& t : one.triangles)
      if (t.minCoeff() < 0 || t.maxCoeff() >= static_cast<int>(one.vertices.size())) std::abort();
    (void)depowder::closednessProblem(one, data[0] & 4);
  } catch (const depowder::MeshError&) {
  }
  return 0;
}
