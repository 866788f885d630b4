#include "depowder/sim/nozzle.hpp"

namespace depowder::sim {

Cloud contactSamples(const Mesh& mesh, double spacing) {
  Cloud points = sampleSurface(mesh, spacing, 7).points;
  points.insert(points.end(), mesh.vertices.begin(), mesh.vertices.end());
  return points;
}

}  // namespace depowder::sim
