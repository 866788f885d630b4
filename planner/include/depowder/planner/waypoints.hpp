// From tip positions to waypoints the arm can run: nozzle orientation, IK (VS-6577) and
// collision checks at every waypoint and along every edge. A waypoint that collides is
// pushed away from the part; one that still collides, or that IK cannot reach, is dropped
// and reported, never sent. Where an edge cannot be run (collision, IK, a joint jump), the
// path is cut into pieces that the plan joins with transitions (transition.hpp).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "depowder/geometry.hpp"
#include "depowder/planner/collision.hpp"
#include "depowder/planner/config.hpp"
#include "depowder/robot/kinematics.hpp"
#include "depowder/tool.hpp"

namespace depowder::planner {

struct Waypoint {
  Pose T_cell_nozzle = Pose::Identity();  ///< nozzle tip pose (z = spray direction)
  Tool tool = Tool::kOff;                 ///< tool state while travelling to and at this waypoint
  double speed = 0;                       ///< m/s of the tip towards this waypoint
  robot::Joints q{};                      ///< the IK solution the plan was checked with, rad
};

/// The nozzle pointing down (-z of the cell) at `tip`, its x axis along the horizontal
/// direction from the robot base to the tip (so J4 and J6 stay put as J1 turns).
Pose nozzleDown(const robot::ArmConfig& arm, const Point& tip);

/// The waypoint of the arm at joints `q` (its nozzle pose by forward kinematics).
Waypoint atJoints(const robot::ArmConfig& arm, const robot::Joints& q, Tool tool = Tool::kOff, double speed = 0);

/// The time the nozzle's tip takes along the waypoints at their speeds, s (a lower bound: the
/// driver may go slower where the joints limit it).
double travelSeconds(const std::vector<Waypoint>& waypoints);

/// Which way a colliding waypoint is pushed.
enum class PushMode {
  kOutward,  ///< horizontally away from `centre` (vacuum loops)
  kUp,       ///< up (+z; air blast from the top)
};

struct PathReport {
  int input = 0;                         ///< tip positions given
  int kept = 0;                          ///< waypoints in the pieces
  int pushed = 0;                        ///< kept after an outward push
  int dropped = 0;                       ///< dropped: collision even after max_push
  int unreachable = 0;                   ///< dropped: no IK solution within the joint limits
  std::vector<int> unreachable_indices;  ///< input indices IK could not reach
  int cuts = 0;                          ///< edges that could not be run (pieces - 1)
  std::string first_contact;             ///< what the first dropped waypoint hit
  std::string summary() const;           ///< e.g. "2 pushed, 1 dropped (nozzle-wall:+x), 0 unreachable"
};

struct RefinedPath {
  std::vector<std::vector<Waypoint>> pieces;  ///< each runnable without a transition
  PathReport report;
  std::size_t size() const;
};

/// IK + collision for every tip (nozzle down), seeded with `seed` and then with the
/// previous waypoint; vacuum paths are checked without the powder obstacle.
RefinedPath refinePath(const CollisionWorld& world, const Cloud& tips, Tool tool, double speed, PushMode push,
                       const Point& centre, const robot::Joints& seed, const PlannerConfig& config);

/// True if the straight tip motion from a to b (orientation slerped) can be run the way the
/// driver runs it: IK nearest the previous solution every edge_step (and every 0.05 rad of
/// nozzle rotation), no joint jump over max_joint_step, no collision, ending at b.q.
bool edgeFree(const CollisionWorld& world, const Waypoint& a, const Waypoint& b, const PlannerConfig& config,
              const CheckOptions& options = {});

}  // namespace depowder::planner
