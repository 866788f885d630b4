#include "depowder/planner/plan.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>

#include "axis_distance.hpp"

namespace depowder::planner {

const char* toString(Phase p) {
  switch (p) {
    case Phase::kNone:
      return "none";
    case Phase::kVacuumBuried:
      return "vacuum (initial pose)";
    case Phase::kVacuumTracked:
      return "vacuum (tracked pose)";
    case Phase::kAirBlast:
      return "air blast";
    case Phase::kDone:
      return "done";
  }
  return "?";
}

const char* toString(PlanStatus s) {
  switch (s) {
    case PlanStatus::kOk:
      return "OK";
    case PlanStatus::kHold:
      return "HOLD";
    case PlanStatus::kNoPath:
      return "NO_PATH";
    case PlanStatus::kTransitionFailed:
      return "TRANSITION_FAILED";
    case PlanStatus::kHome:
      return "HOME";
  }
  return "?";
}

namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

std::string describe(const TransitionResult& t) {
  char buf[96];
  std::snprintf(buf, sizeof(buf), "%s, %.0f ms", toString(t.status), t.planning_ms);
  return buf;
}

/// If the arm is in collision now because a part moved into the margins of the nozzle (the
/// paper's toppling pipe), of the end effector's body or of a link, the way out: straight away
/// from that part, horizontally, every edge_step,
/// while nothing else is hit and the nozzle's distance to the part never shrinks, until the
/// arm is clear; if that way is blocked (another part, the arm's reach, a part that wraps
/// round the nozzle, or the nozzle right above the part), straight up under the same checks.
/// Returns the escaped joints (q_now if nothing to do) or nullopt with `why`.
std::optional<robot::Joints> escape(const CollisionWorld& world, const robot::Joints& q_now,
                                    const PlannerConfig& config, Tool tool, double speed, std::vector<Waypoint>& out,
                                    std::string& why) {
  const Contact contact = world.checkArm(q_now);
  if (!contact) return q_now;
  const int part = contact.part;  // the nozzle, the effector's body or a link against a part
  if (part < 0 || world.checkArm(q_now, CheckOptions(false, true, part))) {
    why = "the arm is in collision (" + contact.what + ")";
    return std::nullopt;
  }
  const robot::ArmConfig& arm = world.arm();
  const std::string& name = world.part(part).name();
  const AxisDistanceField field(world.part(part).mesh(), world.partPose(part));
  const double length = world.nozzle().length;
  const Pose T0 = robot::forwardNozzle(arm, q_now);
  const Point tip0 = T0.translation();
  const auto distance = [&](const Point& tip) { return field.query(tip.x(), tip.y(), tip.z(), tip.z() + length, 1.0); };
  const auto d0 = distance(tip0);
  const double max_move = config.vacuum.standoff + config.collision.lost_margin;
  const int steps = static_cast<int>(std::ceil(max_move / config.collision.edge_step));

  // Waypoints every edge_step along `dir` until the arm is clear; false with `blocked` if not.
  std::vector<Waypoint> way;
  const auto leave = [&](const Eigen::Vector3d& dir, robot::Joints& q, std::string& blocked) {
    way.clear();
    q = q_now;
    double d_prev = d0.distance;
    for (int k = 1; k <= steps; ++k) {
      Pose T = T0;
      T.translation() = tip0 + dir * (k * config.collision.edge_step);
      const auto next = robot::inverseNozzle(arm, T, q);
      double jump = 0;
      if (next)
        for (int i = 0; i < 6; ++i) jump = std::max(jump, std::abs((*next)[i] - q[i]));
      if (!next || jump > config.collision.max_joint_step) {
        blocked = "no IK on the way";
        return false;
      }
      if (const Contact other = world.checkArm(*next, CheckOptions(false, true, part))) {
        blocked = "it would hit " + other.what;
        return false;
      }
      const double d = distance(T.translation()).distance;
      if (d < d_prev - 1e-4) {
        blocked = "the nozzle would come closer to it";
        return false;
      }
      d_prev = d;
      q = *next;
      Waypoint w;
      w.T_cell_nozzle = T;
      w.tool = tool;
      w.speed = speed;
      w.q = q;
      way.push_back(w);
      if (!world.checkArm(q)) return true;
    }
    blocked = "still too close after " + std::to_string(static_cast<int>(std::lround(1000 * max_move))) + " mm";
    return false;
  };

  Eigen::Vector3d away = d0.cut_off ? Eigen::Vector3d::Zero() : Eigen::Vector3d(d0.on_axis - d0.on_part);
  away.z() = 0;
  if (away.norm() < 1e-9) away = tip0 - world.partPose(part).translation();
  away.z() = 0;
  std::string sideways = "the nozzle is above it", upwards;
  robot::Joints q;
  if ((away.norm() >= 1e-9 && leave(away.normalized(), q, sideways)) || leave(Eigen::Vector3d::UnitZ(), q, upwards)) {
    out.insert(out.end(), way.begin(), way.end());
    return q;
  }
  why = "no way out of " + name + " (sideways: " + sideways + "; up: " + upwards + ")";
  return std::nullopt;
}

}  // namespace

Plan planCycle(const CollisionWorld& world, const CycleRequest& request, const PlannerConfig& config) {
  const auto t0 = Clock::now();
  Plan plan;
  const PartShape& part = world.part(request.part);
  plan.part = part.name();
  plan.phase = request.phase;
  const Pose& T_cell_part = world.partPose(request.part);
  const robot::ArmConfig& arm = world.arm();
  const Point nozzle_now = robot::forwardNozzle(arm, request.q_now).translation();

  // 1. The phase's path (tip positions).
  Cloud tips;
  Tool tool = Tool::kVacuum;
  double speed = config.vacuum.speed;
  PushMode push = PushMode::kOutward;
  std::string what;
  if (request.phase == Phase::kVacuumBuried || request.phase == Phase::kVacuumTracked) {
    // The loop runs where the collision check lets the nozzle be: at the stand-off, or just
    // outside the nozzle's radius and margins around this part if they need more (25 mm <
    // 12.5 + 2.5 + 12 mm by default). Built at the stand-off, every waypoint would be pushed out
    // step by step in refinePath: a fifth of a new loop's planning (depowder-planner-bench).
    const double margin = world.partState(request.part) == PartState::kLost ? config.collision.lost_margin
                                                                            : config.collision.tracking_margin;
    PlannerConfig loop_config = config;
    loop_config.vacuum.standoff = std::max(config.vacuum.standoff, config.nozzle.radius + config.nozzle.margin +
                                                                       margin + 0.5 * config.collision.push_step);
    LoopResult loop;
    std::string fallback;
    if (!request.contour.empty()) {
      loop = contourLoop(part, T_cell_part, request.contour, request.powder_height, nozzle_now, loop_config);
      if (!loop.ok()) fallback = loop.reason;
    } else {
      fallback = request.no_contour.empty() ? "no contour" : request.no_contour;
    }
    if (!loop.ok() && loop.status != PathStatus::kInvalidPose && loop.status != PathStatus::kInvalidHeight)
      loop = footprintLoop(part, T_cell_part, request.powder_height, nozzle_now, loop_config);
    if (!loop.ok()) {
      plan.status = PlanStatus::kNoPath;
      plan.reason = "hold: no vacuum loop for " + part.name() + ": " + loop.reason;
      plan.planning_ms = msSince(t0);
      return plan;
    }
    plan.source = loop.source;
    tips = std::move(loop.tips);
    char buf[160];
    std::snprintf(buf, sizeof(buf), "%s loop at z %.3f m, stand-off %.1f-%.1f mm", toString(loop.source), loop.height,
                  1000 * loop.min_standoff, 1000 * loop.max_standoff);
    what = buf;
    if (loop.source == LoopSource::kFootprint) what += " (" + fallback + ")";
  } else if (request.phase == Phase::kAirBlast) {
    const RasterResult raster = blastRaster(part, T_cell_part, nozzle_now, config);
    if (!raster.ok()) {
      plan.status = PlanStatus::kNoPath;
      plan.reason = "hold: no air-blast raster for " + part.name() + ": " + raster.reason;
      plan.planning_ms = msSince(t0);
      return plan;
    }
    tips = raster.tips;
    tool = Tool::kAir;
    speed = config.blast.speed;
    push = PushMode::kUp;
    what = "air-blast raster, " + std::to_string(raster.lines) + " lines";
  } else {
    plan.status = PlanStatus::kHold;
    plan.reason = "hold: nothing to do for " + part.name() + " in phase " + toString(request.phase);
    plan.planning_ms = msSince(t0);
    return plan;
  }
  plan.path_ms = msSince(t0);

  // 2. IK and collision at every waypoint and edge; cut where an edge cannot be run.
  const Point centre = T_cell_part.translation();
  const RefinedPath refined = refinePath(world, tips, tool, speed, push, centre, request.q_now, config);
  plan.report = refined.report;
  plan.path_waypoints = static_cast<int>(refined.size());
  if (refined.pieces.empty()) {
    plan.status = PlanStatus::kNoPath;
    plan.reason = "hold: no reachable collision-free waypoint around " + part.name() + ": " + refined.report.summary();
    plan.planning_ms = msSince(t0);
    return plan;
  }

  // 3. Out of a part's margin if it moved onto the nozzle; then enter the first piece: straight
  //    if the nozzle is next to it, else a transition.
  std::string why;
  const auto q_start = escape(world, request.q_now, config, tool, speed, plan.waypoints, why);
  if (!q_start) {
    plan.status = PlanStatus::kTransitionFailed;
    plan.reason = "hold: " + why;
    plan.waypoints.clear();
    plan.planning_ms = msSince(t0);
    return plan;
  }
  const Waypoint now = atJoints(arm, *q_start);
  const Waypoint& first = refined.pieces.front().front();
  const double gap = (first.T_cell_nozzle.translation() - now.T_cell_nozzle.translation()).norm();
  std::string entry = plan.waypoints.empty() ? "entered directly" : "escaped from the part, entered directly";
  if (gap > config.transition.direct_move || !edgeFree(world, now, first, config)) {
    TransitionResult t = planTransition(world, *q_start, first.q, config, request.try_direct);
    plan.transitions.push_back(t);
    if (!t.ok()) {
      plan.status = PlanStatus::kTransitionFailed;
      plan.reason = "hold: cannot reach " + part.name() + ": " + t.reason;
      plan.planning_ms = msSince(t0);
      return plan;
    }
    auto moves = pathWaypoints(arm, t.path, config.transition.speed);
    moves.pop_back();  // the path's last state is the first waypoint itself
    plan.waypoints.insert(plan.waypoints.end(), moves.begin(), moves.end());
    entry = (plan.waypoints.size() > moves.size() ? "escaped, " : "") + std::string("entry transition ") + describe(t);
  }

  // 4. The pieces, joined by transitions; stop at a gap that cannot be bridged.
  int joined = 0;
  std::string stopped;
  for (std::size_t k = 0; k < refined.pieces.size(); ++k) {
    if (k > 0) {
      TransitionResult t = planTransition(world, refined.pieces[k - 1].back().q, refined.pieces[k].front().q, config,
                                          request.try_direct);
      plan.transitions.push_back(t);
      if (!t.ok()) {
        stopped = ", stopped before piece " + std::to_string(k + 1) + " of " + std::to_string(refined.pieces.size()) +
                  " (" + t.reason + ")";
        break;
      }
      auto moves = pathWaypoints(arm, t.path, config.transition.speed);
      moves.pop_back();
      plan.waypoints.insert(plan.waypoints.end(), moves.begin(), moves.end());
      ++joined;
    }
    plan.waypoints.insert(plan.waypoints.end(), refined.pieces[k].begin(), refined.pieces[k].end());
  }
  plan.status = PlanStatus::kOk;
  plan.reason = what + "; " + refined.report.summary() + "; " + entry;
  if (joined > 0) plan.reason += "; " + std::to_string(joined) + " transitions between pieces";
  plan.reason += stopped;
  plan.planning_ms = msSince(t0);
  return plan;
}

Plan planHome(const CollisionWorld& world, const robot::Joints& q_now, const PlannerConfig& config,
              const std::string& why) {
  const auto t0 = Clock::now();
  Plan plan;
  const robot::ArmConfig& arm = world.arm();
  std::string stuck;
  const auto q_start = escape(world, q_now, config, Tool::kOff, config.transition.speed, plan.waypoints, stuck);
  if (!q_start) {
    plan.status = PlanStatus::kTransitionFailed;
    plan.reason = "hold: cannot go home (" + why + "): " + stuck;
    plan.waypoints.clear();
    plan.planning_ms = msSince(t0);
    return plan;
  }
  TransitionResult t = planTransition(world, *q_start, arm.q_home, config);
  plan.transitions.push_back(t);
  if (!t.ok()) {
    // The way out of a part, if any, is kept (as planCycle keeps it): away from it at least.
    plan.status = PlanStatus::kTransitionFailed;
    plan.reason = "hold: cannot go home (" + why + "): " + t.reason;
    if (plan.hasWaypoints()) plan.reason += "; escaped from the part";
  } else {
    plan.status = PlanStatus::kHome;
    const auto moves = pathWaypoints(arm, t.path, config.transition.speed);
    plan.waypoints.insert(plan.waypoints.end(), moves.begin(), moves.end());
    plan.reason = "home: " + why + "; transition " + describe(t);
  }
  plan.planning_ms = msSince(t0);
  return plan;
}

}  // namespace depowder::planner
