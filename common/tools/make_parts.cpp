// depowder-make-parts OUTDIR: writes OUTDIR/<name>.stl (binary, metres) for each default part
// and prints its triangle count, bounding box, diagonal and volume.
#include <cstdio>
#include <exception>
#include <string>

#include "depowder/mesh.hpp"
#include "depowder/parts.hpp"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s OUTDIR\n  writes OUTDIR/<name>.stl for each default part\n", argv[0]);
    return 2;
  }
  const std::string outdir = argv[1];
  try {
    std::printf("%-10s %9s  %-22s %9s %12s\n", "part", "triangles", "bbox x y z (cm)", "diag (cm)", "volume (cm3)");
    for (const auto& name : depowder::parts::names()) {
      const depowder::Mesh mesh = depowder::parts::byName(name);
      depowder::saveStl(mesh, outdir + "/" + name + ".stl");
      const Eigen::Vector3d size = depowder::bounds(mesh).sizes() * 100.0;
      std::printf("%-10s %9zu  %6.2f %6.2f %6.2f   %9.2f %12.2f\n", name.c_str(), mesh.triangles.size(), size.x(),
                  size.y(), size.z(), size.norm(), depowder::volume(mesh) * 1e6);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "depowder-make-parts: %s\n", e.what());
    return 1;
  }
  return 0;
}
