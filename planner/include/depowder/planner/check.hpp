// An independent check of finished waypoints, for tests and benchmarks: its own FCL
// objects built from the meshes, the exact nozzle cylinder and link capsules (no margins),
// FCL *distance* against the TRUE part poses (e.g. the simulator's SIM_TRUTH). It shares
// no code with CollisionWorld, so a bug there cannot hide here.
#pragma once

#include <string>
#include <vector>

#include "depowder/mesh.hpp"
#include "depowder/planner/config.hpp"
#include "depowder/planner/waypoints.hpp"
#include "depowder/robot/kinematics.hpp"

namespace depowder::planner {

struct TruePart {
  std::string name;
  Mesh mesh;                            ///< part frame
  Pose T_cell_part = Pose::Identity();  ///< the true pose
};

struct CheckReport {
  int waypoints = 0;
  int in_collision = 0;          ///< waypoints where nozzle or a link touches a part, wall or floor
  int ik_mismatch = 0;           ///< waypoints whose q does not put the nozzle at T_cell_nozzle (1 mm, 0.01 rad)
  double min_nozzle_part = 1e9;  ///< m, smallest nozzle-to-part distance over all waypoints
  double min_arm_part = 1e9;     ///< m, smallest link-to-part distance
  double min_to_box = 1e9;       ///< m, smallest nozzle or link distance to walls and floor
  std::vector<int> colliding;    ///< indices of the waypoints in collision
  std::string first;             ///< what the first colliding waypoint touched
  bool clean() const { return in_collision == 0 && ik_mismatch == 0; }
};

/// Checks every waypoint: nozzle (radius x length above the tip, as configured, no margin)
/// at T_cell_nozzle, and the arm's link capsules at q, against the parts at their true poses
/// and the box. `include_arm` false checks the nozzle only.
CheckReport checkWaypoints(const std::vector<Waypoint>& waypoints, const std::vector<TruePart>& parts, const Box& box,
                           const robot::ArmConfig& arm, const NozzleConfig& nozzle, bool include_arm = true);

}  // namespace depowder::planner
