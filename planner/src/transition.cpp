#include "depowder/planner/transition.hpp"

#include <ompl/base/spaces/RealVectorStateSpace.h>
#include <ompl/geometric/SimpleSetup.h>
#include <ompl/geometric/planners/rrt/RRTConnect.h>
#include <ompl/util/Console.h>
#include <ompl/util/RandomNumbers.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <mutex>

#include "depowder/planner/paths.hpp"

namespace ob = ompl::base;
namespace og = ompl::geometric;

namespace depowder::planner {

const char* toString(TransitionStatus s) {
  switch (s) {
    case TransitionStatus::kDirect:
      return "DIRECT";
    case TransitionStatus::kExact:
      return "EXACT_SOLUTION";
    case TransitionStatus::kApproximate:
      return "APPROXIMATE_SOLUTION";
    case TransitionStatus::kTimeout:
      return "TIMEOUT";
    case TransitionStatus::kInvalidStart:
      return "INVALID_START";
    case TransitionStatus::kInvalidGoal:
      return "INVALID_GOAL";
    case TransitionStatus::kBlocked:
      return "BLOCKED";
    case TransitionStatus::kFailed:
      return "FAILED";
  }
  return "?";
}

namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

double maxJointStep(const robot::Joints& a, const robot::Joints& b) {
  double m = 0;
  for (int i = 0; i < 6; ++i) m = std::max(m, std::abs(a[i] - b[i]));
  return m;
}

/// Appends b to `path` (which ends at a) with intermediate states, none more than `step` apart.
void appendDense(std::vector<robot::Joints>& path, const robot::Joints& b, double step) {
  const robot::Joints a = path.back();
  const int n = std::max(1, static_cast<int>(std::ceil(maxJointStep(a, b) / step)));
  for (int k = 1; k <= n; ++k) {
    robot::Joints q;
    for (int i = 0; i < 6; ++i) q[i] = a[i] + (b[i] - a[i]) * k / n;
    path.push_back(q);
  }
}

/// The straight joint-space line, checked every `resolution` rad.
bool lineFree(const CollisionWorld& world, const robot::Joints& a, const robot::Joints& b, double resolution,
              bool include_powder) {
  const int n = std::max(1, static_cast<int>(std::ceil(maxJointStep(a, b) / resolution)));
  for (int k = 0; k <= n; ++k) {
    robot::Joints q;
    for (int i = 0; i < 6; ++i) q[i] = a[i] + (b[i] - a[i]) * k / n;
    if (world.checkArm(q, include_powder)) return false;
  }
  return true;
}

void configureOmpl(std::uint32_t seed) {
  // OMPL's seed is global and takes effect only before its first random generator exists.
  static std::once_flag once;
  std::call_once(once, [seed] {
    ompl::msg::setLogLevel(ompl::msg::LOG_WARN);
    ompl::RNG::setSeed(seed);
  });
}

TransitionStatus fromOmpl(ob::PlannerStatus s) {
  switch (ob::PlannerStatus::StatusType(s)) {
    case ob::PlannerStatus::EXACT_SOLUTION:
      return TransitionStatus::kExact;
    case ob::PlannerStatus::APPROXIMATE_SOLUTION:
      return TransitionStatus::kApproximate;
    case ob::PlannerStatus::TIMEOUT:
      return TransitionStatus::kTimeout;
    case ob::PlannerStatus::INVALID_START:
      return TransitionStatus::kInvalidStart;
    case ob::PlannerStatus::INVALID_GOAL:
      return TransitionStatus::kInvalidGoal;
    default:
      return TransitionStatus::kFailed;
  }
}

/// Joint states of a vertical tip move from q's tip to height z (same orientation), every edge_step;
/// empty if IK fails, a joint jumps or a state collides. The nozzle moves along its own axis, so
/// the powder is no obstacle and a LOST part counts with the tracked margin (the nozzle may have
/// been next to it when it got lost; going straight up is the way out).
std::vector<robot::Joints> verticalMove(const CollisionWorld& world, const robot::Joints& q0, double z,
                                        const PlannerConfig& config, std::string* why) {
  const robot::ArmConfig& arm = world.arm();
  const Pose T0 = robot::forwardNozzle(arm, q0);
  std::vector<robot::Joints> out{q0};
  const double dz = z - T0.translation().z();
  const int n = std::max(1, static_cast<int>(std::ceil(std::abs(dz) / config.collision.edge_step)));
  for (int k = 1; k <= n; ++k) {
    Pose T = T0;
    T.translation().z() += dz * k / n;
    const auto q = robot::inverseNozzle(arm, T, out.back());
    if (!q) {
      *why = "no IK solution at z = " + std::to_string(T.translation().z());
      return {};
    }
    if (maxJointStep(out.back(), *q) > config.collision.max_joint_step) {  // a branch flip
      *why = "joint jump at z = " + std::to_string(T.translation().z());
      return {};
    }
    if (const Contact c = world.checkArm(*q, CheckOptions(false, false))) {
      *why = c.what + " at z = " + std::to_string(T.translation().z());
      return {};
    }
    out.push_back(*q);
  }
  return out;
}

}  // namespace

TransitionResult planJointPath(const CollisionWorld& world, const robot::Joints& start, const robot::Joints& goal,
                               const TransitionConfig& config, bool include_powder, bool try_direct) {
  const auto t0 = Clock::now();
  TransitionResult r;
  if (const Contact c = world.checkArm(start, include_powder)) {
    r.status = TransitionStatus::kInvalidStart;
    r.reason = "start in collision: " + c.what;
    r.planning_ms = msSince(t0);
    return r;
  }
  if (const Contact c = world.checkArm(goal, include_powder)) {
    r.status = TransitionStatus::kInvalidGoal;
    r.reason = "goal in collision: " + c.what;
    r.planning_ms = msSince(t0);
    return r;
  }
  r.path = {start};
  if (try_direct && lineFree(world, start, goal, config.check_resolution, include_powder)) {
    appendDense(r.path, goal, config.waypoint_step);
    r.status = TransitionStatus::kDirect;
    r.planning_ms = msSince(t0);
    return r;
  }

  configureOmpl(config.seed);
  const robot::ArmConfig& arm = world.arm();
  auto space = std::make_shared<ob::RealVectorStateSpace>(6);
  ob::RealVectorBounds bounds(6);
  for (int i = 0; i < 6; ++i) {
    bounds.setLow(i, arm.q_min[i]);
    bounds.setHigh(i, arm.q_max[i]);
  }
  space->setBounds(bounds);
  og::SimpleSetup ss(space);
  ss.setStateValidityChecker([&world, include_powder](const ob::State* s) {
    const double* v = s->as<ob::RealVectorStateSpace::StateType>()->values;
    return !world.checkArm({v[0], v[1], v[2], v[3], v[4], v[5]}, include_powder);
  });
  ss.getSpaceInformation()->setStateValidityCheckingResolution(config.check_resolution / space->getMaximumExtent());
  ss.setPlanner(std::make_shared<og::RRTConnect>(ss.getSpaceInformation()));
  ob::ScopedState<> a(space), b(space);
  for (int i = 0; i < 6; ++i) {
    a[i] = start[i];
    b[i] = goal[i];
  }
  ss.setStartAndGoalStates(a, b);
  const ob::PlannerStatus status = ss.solve(config.time_limit);
  r.ompl_status = status.asString();
  r.status = fromOmpl(status);
  if (r.status != TransitionStatus::kExact) {
    r.reason = "OMPL: " + r.ompl_status;
    r.path.clear();
    r.planning_ms = msSince(t0);
    return r;
  }
  // Simplify with what is left of the time limit (at least a little).
  const double left = std::max(0.02, config.time_limit - msSince(t0) / 1000.0);
  ss.simplifySolution(left);
  const og::PathGeometric& solution = ss.getSolutionPath();
  for (std::size_t k = 1; k < solution.getStateCount(); ++k) {
    const double* v = solution.getState(k)->as<ob::RealVectorStateSpace::StateType>()->values;
    appendDense(r.path, {v[0], v[1], v[2], v[3], v[4], v[5]}, config.waypoint_step);
  }
  r.path.back() = goal;
  r.planning_ms = msSince(t0);
  return r;
}

double safeHeight(const CollisionWorld& world, const TransitionConfig& config) {
  double top = world.powderTop();
  for (std::size_t i = 0; i < world.numParts(); ++i)
    if (world.partState(i) != PartState::kIgnored)
      top = std::max(top, partHeights(world.part(i), world.partPose(i)).max);
  return top + config.clearance;
}

namespace {

/// The driver runs waypoints as straight Cartesian steps with IK, not along the joint-space
/// line OMPL validated: checks every step of the path that way, inserting joint-space
/// midpoints (which lie on the validated line) where the Cartesian step fails. The steps
/// between path[middle_from] and path[middle_to] (OMPL's) are checked as OMPL checked them,
/// the powder an obstacle and LOST parts with their margin; the vertical lift and descent
/// leave the powder, with LOST parts as in verticalMove.
bool verifyCartesian(const CollisionWorld& world, std::vector<robot::Joints>& path, std::size_t middle_from,
                     std::size_t middle_to, const PlannerConfig& config, std::string* why) {
  const robot::ArmConfig& arm = world.arm();
  std::vector<robot::Joints> out{path.front()};
  for (std::size_t k = 1; k < path.size(); ++k) {
    const bool middle = k - 1 >= middle_from && k <= middle_to;
    const CheckOptions options(middle, middle);
    std::vector<robot::Joints> todo{path[k]};
    int splits = 0;
    while (!todo.empty()) {
      const robot::Joints next = todo.back();
      if (edgeFree(world, atJoints(arm, out.back()), atJoints(arm, next), config, options)) {
        out.push_back(next);
        todo.pop_back();
        continue;
      }
      if (++splits > 16) {
        *why = "the Cartesian move between two transition states collides or flips the arm";
        return false;
      }
      robot::Joints mid;
      for (int i = 0; i < 6; ++i) mid[i] = 0.5 * (out.back()[i] + next[i]);
      todo.push_back(mid);
    }
  }
  path = std::move(out);
  return true;
}

}  // namespace

TransitionResult planTransition(const CollisionWorld& world, const robot::Joints& start, const robot::Joints& goal,
                                const PlannerConfig& config, bool try_direct) {
  const auto t0 = Clock::now();
  const robot::ArmConfig& arm = world.arm();
  const double z = safeHeight(world, config.transition);
  TransitionResult r;
  std::vector<robot::Joints> lift{start}, descent{goal};
  std::string why;
  if (robot::forwardNozzle(arm, start).translation().z() < z) {
    lift = verticalMove(world, start, z, config, &why);
    if (lift.empty()) {
      r.status = TransitionStatus::kBlocked;
      r.reason = "lift blocked: " + why;
      r.planning_ms = msSince(t0);
      return r;
    }
  }
  if (robot::forwardNozzle(arm, goal).translation().z() < z) {
    descent = verticalMove(world, goal, z, config, &why);
    if (descent.empty()) {
      r.status = TransitionStatus::kBlocked;
      r.reason = "descent blocked: " + why;
      r.planning_ms = msSince(t0);
      return r;
    }
    std::reverse(descent.begin(), descent.end());
  }
  r = planJointPath(world, lift.back(), descent.front(), config.transition, true, try_direct);
  if (r.ok()) {
    std::vector<robot::Joints> path = lift;
    path.insert(path.end(), r.path.begin() + 1, r.path.end());
    path.insert(path.end(), descent.begin() + 1, descent.end());
    const std::size_t middle_from = lift.size() - 1, middle_to = middle_from + r.path.size() - 1;
    r.path = std::move(path);
    if (!verifyCartesian(world, r.path, middle_from, middle_to, config, &why)) {
      r.status = TransitionStatus::kBlocked;
      r.reason = why;
      r.path.clear();
    }
  }
  r.planning_ms = msSince(t0);
  return r;
}

std::vector<Waypoint> pathWaypoints(const robot::ArmConfig& arm, const std::vector<robot::Joints>& path, double speed) {
  std::vector<Waypoint> out;
  for (std::size_t k = 1; k < path.size(); ++k) out.push_back(atJoints(arm, path[k], Tool::kOff, speed));
  return out;
}

}  // namespace depowder::planner
