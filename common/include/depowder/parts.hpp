// The default cell's five parts, generated procedurally like the paper's test set
// (Fig. 6): cube, cup, propeller, owl, pipe; 8 to 15 cm bounding-box diagonal.
// Part frame: origin at the centre of the bounding box, z up as printed, metres.
#pragma once

#include <string>
#include <vector>

#include "depowder/mesh.hpp"

namespace depowder::parts {

Mesh cube();
Mesh cup();
Mesh propeller();
Mesh owl();
Mesh pipe();

/// An axis-aligned box of `size` (m) centred at the origin, outward winding, each face split
/// into divisions x divisions squares (the cube's faces are, for contact models and samplers).
Mesh box(const Eigen::Vector3d& size, int divisions = 1);

/// "cube", "cup", "propeller", "owl", "pipe".
const std::vector<std::string>& names();
/// The part called `name`; throws std::invalid_argument naming the known parts.
Mesh byName(const std::string& name);

}  // namespace depowder::parts
