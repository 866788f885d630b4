// depowder-make-parts OUTDIR: writes OUTDIR/<name>.stl (binary, metres) for each default part
// and prints its triangle count, bounding box, diagonal and volume.
// depowder-make-parts --shell POINTS OUT.stl [--scale S] [--radius M] [--voxel M]: a closed
// mesh around a CAD model given as surface points ("x y z" lines, e.g. the authors' P_cad of the
// pipe in cm: --scale 0.01), so that the simulator can place it and the evaluation track it.
// depowder-make-parts --check MESH... [--scale S]: whether each mesh bounds a solid, as the
// simulator needs (the tracker takes any surface); exits 1 if one does not.
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <utility>
#include <vector>

#include "depowder/files.hpp"
#include "depowder/mesh.hpp"
#include "depowder/parts.hpp"

namespace {

void printRow(const std::string& name, const depowder::Mesh& mesh) {
  static bool header = false;
  if (!std::exchange(header, true))
    std::printf("%-10s %9s  %-22s %9s %12s\n", "part", "triangles", "bbox x y z (cm)", "diag (cm)", "volume (cm3)");
  const Eigen::Vector3d size = depowder::bounds(mesh).sizes() * 100.0;
  std::printf("%-10s %9zu  %6.2f %6.2f %6.2f   %9.2f %12.2f\n", name.c_str(), mesh.triangles.size(), size.x(), size.y(),
              size.z(), size.norm(), depowder::volume(mesh) * 1e6);
}

/// A number > 0 from a whole argument, else false.
bool readPositive(const char* text, double& value) {
  char* end = nullptr;
  value = std::strtod(text, &end);
  return *end == '\0' && value > 0;
}

int usage(const char* argv0, const std::string& why) {
  std::fprintf(stderr,
               "%s: %s\nusage: %s OUTDIR\n  writes OUTDIR/<name>.stl for each default part\n"
               "       %s --shell POINTS OUT.stl [--scale S] [--radius M] [--voxel M]\n"
               "  a closed mesh around surface points (x y z lines, times S: default 1; radius default\n"
               "  0.0015 m, voxel 0.001 m)\n"
               "       %s --check MESH... [--scale S]\n"
               "  whether each mesh (.stl, .obj, .ply, times S: default 1) bounds a solid, as the simulator\n"
               "  needs: closed, wound outward; exit 1 if one does not\n",
               argv0, why.c_str(), argv0, argv0, argv0);
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    if (argc >= 2 && std::string(argv[1]) == "--shell") {
      if (argc < 4) return usage(argv[0], "--shell needs POINTS and OUT.stl");
      double scale = 1, radius = 0.0015, voxel = 0.001;
      for (int i = 4; i < argc; i += 2) {
        const std::string flag = argv[i];
        double* value = flag == "--scale"    ? &scale
                        : flag == "--radius" ? &radius
                        : flag == "--voxel"  ? &voxel
                                             : nullptr;
        if (!value) return usage(argv[0], "unknown flag '" + flag + "'");
        if (i + 1 >= argc || !readPositive(argv[i + 1], *value)) return usage(argv[0], flag + " needs a number > 0");
      }
      const depowder::Mesh mesh = depowder::shellAround(depowder::readXyz(argv[2], scale), radius, voxel);
      depowder::saveStl(mesh, argv[3]);
      printRow(argv[3], mesh);
      return 0;
    }
    if (argc >= 2 && std::string(argv[1]) == "--check") {
      double scale = 1;
      std::vector<std::string> paths;
      for (int i = 2; i < argc; ++i) {
        if (std::string(argv[i]) != "--scale") {
          paths.emplace_back(argv[i]);
          continue;
        }
        if (++i >= argc || !readPositive(argv[i], scale)) return usage(argv[0], "--scale needs a number > 0");
      }
      if (paths.empty()) return usage(argv[0], "--check needs a mesh file");
      int refused = 0;
      for (const std::string& path : paths) {
        std::string problem;
        try {
          const depowder::Mesh mesh = depowder::loadMesh(path, scale);
          printRow(path, mesh);
          problem = depowder::solidProblem(mesh);
        } catch (const depowder::MeshError& e) {
          problem = e.what();
        }
        std::printf("  %s\n", problem.empty() ? "bounds a solid: the simulator takes it" : problem.c_str());
        refused += !problem.empty();
      }
      return refused ? 1 : 0;
    }
    if (argc != 2 || argv[1][0] == '-') return usage(argv[0], "expected OUTDIR, --shell or --check");
    for (const auto& name : depowder::parts::names()) {
      const depowder::Mesh mesh = depowder::parts::byName(name);
      depowder::saveStl(mesh, std::string(argv[1]) + "/" + name + ".stl");
      printRow(name, mesh);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "depowder-make-parts: %s\n", e.what());
    return 1;
  }
  return 0;
}
