// Part meshes from the user (loadMesh, by extension): a malformed file is a MeshError, never a
// crash, and a mesh that loads has every triangle index inside its vertices. The first byte picks
// the format; the rest is the file.
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "depowder/mesh.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  static const char* const kExtensions[] = {".stl", ".obj", ".ply"};
  const std::string path = (std::filesystem::temp_directory_path() / "depowder-fuzz-").string() +
                           std::to_string(::getpid()) + kExtensions[data[0] % 3];
  std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(data + 1), size - 1);
  try {
    const depowder::Mesh mesh = depowder::loadMesh(path);
    for (const Eigen::Vector3i& t : mesh.triangles)
      if (t.minCoeff() < 0 || t.maxCoeff() >= static_cast<int>(mesh.vertices.size())) std::abort();
  } catch (const depowder::MeshError&) {
  }
  ::unlink(path.c_str());
  return 0;
}
