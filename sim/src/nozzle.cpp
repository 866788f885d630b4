#include "depowder/sim/nozzle.hpp"

#include <cmath>

namespace depowder::sim {

Mesh makeNozzleMesh(const NozzleGeometry& g) {
  Mesh m;
  const int n = std::max(3, g.segments);
  for (int k = 0; k < n; ++k) {
    const double a = 2 * M_PI * k / n;
    m.vertices.emplace_back(g.radius * std::cos(a), g.radius * std::sin(a), 0.0);        // 2k: tip ring
    m.vertices.emplace_back(g.radius * std::cos(a), g.radius * std::sin(a), -g.length);  // 2k+1: top ring
  }
  const int tip = static_cast<int>(m.vertices.size());
  m.vertices.emplace_back(0, 0, 0);
  const int top = tip + 1;
  m.vertices.emplace_back(0, 0, -g.length);
  for (int k = 0; k < n; ++k) {
    const int a0 = 2 * k, a1 = 2 * k + 1, b0 = 2 * ((k + 1) % n), b1 = b0 + 1;
    m.triangles.emplace_back(a0, a1, b1);  // side, facing out
    m.triangles.emplace_back(a0, b1, b0);
    m.triangles.emplace_back(tip, a0, b0);  // tip disc, facing +z
    m.triangles.emplace_back(top, b1, a1);  // top disc, facing -z
  }
  return m;
}

Cloud contactSamples(const Mesh& mesh, double spacing) {
  Cloud points = sampleSurface(mesh, spacing, 7).points;
  points.insert(points.end(), mesh.vertices.begin(), mesh.vertices.end());
  return points;
}

}  // namespace depowder::sim
