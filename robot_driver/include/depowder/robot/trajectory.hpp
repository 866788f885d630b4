// From NOZZLE_PLAN waypoints to joint targets every 8 ms (the slave-mode cycle).
//
// preparePlan(): each waypoint's path from the previous one (the first from the current
// nozzle pose) is split into short Cartesian steps (straight line, slerped orientation), each
// solved by IK nearest the previous solution; the plan is refused if a step is unreachable,
// leaves the workspace box or makes a joint jump (a branch flip). Waypoint speeds above the
// limit are clipped.
//
// TrajectoryGenerator: the joint path is a chain of straight joint-space segments. A scalar
// path speed is planned GRBL-style: each segment has a speed limit (joint speeds and the
// waypoint's nozzle speed), each junction a limit from the joint-velocity change it causes
// within one cycle, a backward pass gives the fastest speed that can still stop at the end,
// and every cycle the speed rises or falls by at most the segment's acceleration limit. A new
// plan is joined without a jump: it takes over as soon as the current path speed is within
// what the new path can absorb at its start (braking on the current path until then).
// A controlled stop brakes along the current path and holds.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "depowder/robot/kinematics.hpp"
#include "depowder/tool.hpp"

namespace depowder::robot {

/// Axis-aligned box the nozzle tip must stay in, cell frame.
struct Workspace {
  Eigen::Vector3d min{-0.20, -0.15, 0.0};  ///< m
  Eigen::Vector3d max{0.20, 0.15, 0.60};   ///< m
  bool contains(const Eigen::Vector3d& p, double margin = 0.0) const;
};

struct TrajectoryConfig {
  double cycle_s = 0.008;                  ///< s, one slave-mode cycle
  double max_nozzle_speed = 0.25;          ///< m/s, waypoint speeds above are clipped to this
  double max_nozzle_rotation_speed = 2.0;  ///< rad/s, nozzle orientation change rate limit
  double velocity_scale = 0.9;             ///< fraction of ArmConfig::qd_max the trajectory plans with
  double acceleration_scale = 0.8;         ///< fraction of ArmConfig::qdd_max the trajectory plans with
  double cartesian_step = 0.01;            ///< m, longest Cartesian step between IK points
  double rotation_step = 0.05;             ///< rad, largest orientation change between IK points
  double max_joint_jump = 0.35;            ///< rad, larger joint change between IK points = branch flip: refuse
};

struct PlanWaypoint {
  Pose T_cell_nozzle = Pose::Identity();  ///< nozzle tip pose (z axis = spray direction)
  Tool tool = Tool::kOff;                 ///< while travelling to and at this waypoint
  double speed = 0.05;                    ///< m/s, nozzle speed to reach it
};

struct Plan {
  std::int64_t id = -1;
  std::int64_t utime = 0;  ///< of the POINTS frame it was made from
  std::vector<PlanWaypoint> waypoints;
};

enum class PlanStatus {
  Accepted,          ///< every waypoint as requested
  Clipped,           ///< accepted, some speeds were clipped to max_nozzle_speed
  Empty,             ///< no waypoints: means "stop and hold"
  InvalidWaypoint,   ///< non-finite or invalid pose, non-positive or non-finite speed, unknown tool
  OutsideWorkspace,  ///< a waypoint or the path to it leaves the workspace box
  Unreachable,       ///< no IK solution within the joint limits
  JointJump,         ///< consecutive IK points too far apart in joint space (branch flip)
};

const char* toString(PlanStatus s);

/// A joint-space point of the prepared path.
struct PathPoint {
  Joints q{};
  double speed = 0;      ///< m/s, nozzle speed limit on the way to this point
  double cart_step = 0;  ///< m, nozzle distance from the previous point
  double rot_step = 0;   ///< rad, nozzle orientation change from the previous point
  Tool tool = Tool::kOff;
  int waypoint = 0;  ///< index of the plan waypoint this point leads to
};

struct PreparedPlan {
  PlanStatus status = PlanStatus::Empty;
  std::string reason;  ///< why refused / what was clipped
  int bad_waypoint = -1;
  int clipped = 0;  ///< waypoint speeds clipped
  std::int64_t id = -1;
  std::int64_t utime = 0;
  int first_waypoint = 0;  ///< index in the original plan of waypoint 0 here (resumed plans)
  std::vector<PathPoint> points;
  bool usable() const { return status == PlanStatus::Accepted || status == PlanStatus::Clipped; }
};

/// Validates `plan` and turns it into joint-space points, starting from the arm at `q_start`.
/// Waypoints before `from_waypoint` are skipped (resuming a plan after a reconnect).
PreparedPlan preparePlan(const ArmConfig& arm, const TrajectoryConfig& cfg, const Workspace& workspace,
                         const Plan& plan, const Joints& q_start, int from_waypoint = 0);

/// One cycle's command.
struct TrajectorySample {
  Joints q{};   ///< rad, position to command
  Joints qd{};  ///< rad/s
  Tool tool = Tool::kOff;
  std::int64_t plan_id = -1;
  int waypoint_index = -1;  ///< next waypoint of the plan (-1 without a plan)
  bool moving = false;
};

class TrajectoryGenerator {
 public:
  TrajectoryGenerator(ArmConfig arm, TrajectoryConfig cfg);

  /// At rest at q, no plan (start-up, reconnect).
  void reset(const Joints& q);
  /// Replaces the plan; it takes over without a jump (see the file comment). An Empty plan
  /// means a controlled stop.
  void setPlan(const PreparedPlan& plan);
  /// Controlled stop: brake along the current path, then hold; the plan is dropped.
  void stop();
  /// Advances one cycle and returns its command.
  TrajectorySample step();

  const TrajectorySample& current() const { return sample_; }
  /// Time a controlled stop started now would take, s: whole cycles, an upper estimate.
  double brakingTime() const;
  bool stopping() const { return stopping_; }
  bool hasPath() const { return segment_ < segments_.size(); }
  /// True once the last plan was run to its end.
  bool finished() const { return finished_; }

 private:
  struct Segment {
    Joints q0{};
    Joints dq{};        ///< q1 - q0
    Joints dir{};       ///< dq / length: joint velocity per unit path speed
    double length = 0;  ///< path units (time at full joint speed)
    double vmax = 0;    ///< path speed limit
    double amax = 0;    ///< path acceleration limit
    double v_end = 0;   ///< largest speed at the end (backward pass)
    Tool tool = Tool::kOff;
    int waypoint = 0;
  };
  std::vector<Segment> buildSegments(const Joints& q_from, const PreparedPlan& plan, double* v_start_max) const;
  Segment makeSegment(const Joints& a, const Joints& b, const PathPoint& to) const;
  double junctionLimit(const Joints& dir_a, const Joints& dir_b) const;
  void tryTakePendingPlan();
  void advance(double dt);
  Joints position() const;

  ArmConfig arm_;
  TrajectoryConfig cfg_;
  std::vector<Segment> segments_;
  std::size_t segment_ = 0;
  double s_ = 0;      ///< position along the current segment, path units
  double speed_ = 0;  ///< path speed
  bool stopping_ = false;
  bool finished_ = false;
  bool pending_ = false;
  PreparedPlan pending_plan_;
  std::int64_t plan_id_ = -1;
  int waypoint_offset_ = 0;
  int last_waypoint_ = 0;
  Joints hold_q_{};
  Joints last_q_{};
  Tool tool_ = Tool::kOff;
  TrajectorySample sample_;
};

}  // namespace depowder::robot
