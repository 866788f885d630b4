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

/// "cube", "cup", "propeller", "owl", "pipe".
const std::vector<std::string>& names();
/// The part called `name`; throws std::invalid_argument naming the known parts.
Mesh byName(const std::string& name);

}  // namespace depowder::parts
