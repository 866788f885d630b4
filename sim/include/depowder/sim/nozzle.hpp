// The cleaning nozzle: a closed cylinder whose tip is the origin of the nozzle frame and
// whose +z axis is the spray direction (pointing down into the box while cleaning), so
// the body extends along -z. A real end-effector mesh may replace it at run time.
#pragma once

#include "depowder/geometry.hpp"
#include "depowder/mesh.hpp"
#include "depowder/tool.hpp"

namespace depowder::sim {

struct NozzleGeometry {
  double radius = 0.0125;  ///< m (2.5 cm diameter)
  double length = 0.13;    ///< m, tip to the flange
  int segments = 24;       ///< facets around
};

/// Points on a mesh's surface (about one per `spacing` m) for contact tests, mesh frame.
Cloud contactSamples(const Mesh& mesh, double spacing);

}  // namespace depowder::sim
