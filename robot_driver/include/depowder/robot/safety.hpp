// Safety enforced in the driver whatever the planner sends: the per-cycle command limiter
// (joint position, speed, acceleration) and the monitor that decides when the arm must stop
// (stale plan, lost planner heartbeat, nozzle outside the workspace). ESTOP is latched by the
// driver itself (driver.hpp). Pure: no clock, no IO; times are passed in.
#pragma once

#include <cstdint>
#include <map>
#include <string>

#include "depowder/robot/kinematics.hpp"
#include "depowder/robot/trajectory.hpp"

namespace depowder::robot {

struct SafetyConfig {
  Workspace workspace;              ///< the nozzle tip must stay inside (cell frame)
  double workspace_margin = 0.005;  ///< m, tolerance of the per-cycle check of the command
  double plan_max_age_s = 1.5;      ///< s, a plan whose utime is older than this is stale: stop
  /// s, a plan whose utime is further ahead of this host's clock than this is refused: the clock of
  /// the host that stamped its camera frame runs ahead of this one's (plan ages need agreeing clocks)
  double plan_max_lead_s = 0.25;
  double planner_heartbeat_timeout_s = 1.0;  ///< s without a planner heartbeat: stop
  bool require_planner_heartbeat = true;     ///< false: ignore heartbeats (bench tests without a planner)
  double limit_tolerance = 1.02;  ///< commands up to this factor over a speed/acceleration limit pass unclipped
};

/// The last line before the wire: every command is clamped to the joint limits and its
/// finite-difference speed and acceleration to the arm's limits.
class CommandLimiter {
 public:
  CommandLimiter(ArmConfig arm, double cycle_s, double tolerance = 1.02);

  /// The arm is at rest at q (start-up, reconnect).
  void reset(const Joints& q);

  struct Result {
    Joints q{};  ///< the command to send
    bool clipped_position = false;
    bool clipped_speed = false;
    bool clipped_acceleration = false;
    bool clipped() const { return clipped_position || clipped_speed || clipped_acceleration; }
  };
  Result apply(const Joints& target);

  const Joints& last() const { return q_; }
  const Joints& velocity() const { return v_; }

 private:
  ArmConfig arm_;
  double dt_;
  double tol_;
  Joints q_{};
  Joints v_{};
};

enum class StopReason {
  None,
  PlanStale,        ///< the executing plan is older than plan_max_age_s
  ClockAhead,       ///< the plan's utime is ahead of this host's clock by more than plan_max_lead_s
  PlannerMismatch,  ///< the planner's heartbeat did not count (PlannerWatch: another arm, two planners)
  HeartbeatLost,    ///< no planner heartbeat for planner_heartbeat_timeout_s
  Workspace,        ///< the commanded nozzle left the workspace box
};

const char* toString(StopReason r);

struct SafetyInputs {
  bool following = false;                            ///< a plan is being executed
  std::int64_t now_utime = 0;                        ///< wall clock, us (plan utimes are wall clock)
  std::int64_t plan_utime = 0;                       ///< utime of the executing plan
  double heartbeat_age_s = 1e9;                      ///< s since the last planner heartbeat (1e9: never)
  Eigen::Vector3d nozzle = Eigen::Vector3d::Zero();  ///< commanded nozzle position, cell frame
  /// s, braking + two cycles + the arm's follow lag: stop this early so it is at rest by the limit
  double stop_lead_s = 0;
  bool was_inside = true;        ///< the previous command was inside (leaving is what stops; an arm that
                                 ///< starts outside may move back in)
  std::string planner_mismatch;  ///< why the planner's last heartbeat did not count ("": it did)
};

struct SafetyVerdict {
  StopReason stop = StopReason::None;
  std::string reason;  ///< human-readable, with the figures
};

/// Whether the arm must come to a controlled stop this cycle. Age limits are applied
/// `stop_lead_s` early, so that the arm is at rest when the limit is reached.
SafetyVerdict checkSafety(const SafetyConfig& cfg, const SafetyInputs& in);

/// Whether a newly received plan may be executed at all (fresh enough, not from the future,
/// planner alive).
SafetyVerdict checkNewPlan(const SafetyConfig& cfg, std::int64_t now_utime, std::int64_t plan_utime,
                           double heartbeat_age_s);

/// The arm the planner plans for and the driver moves must be the same: an identifier of its
/// model (base pose, tool offset, joint limits, speeds, home, IK weights, tool radius) and of the
/// workspace box, from their values (not the file's text). A whole number below 2^52, exact in a
/// heartbeat stat (`arm_model`). On several hosts each reads its own cell file: the driver
/// compares the planner's with its own (PlannerWatch).
double armModelId(const ArmConfig& arm, const Workspace& workspace);

/// Whether the planner heartbeats the driver hears come from the one planner it may follow: a
/// single process of that name on the bus, planning for this driver's arm and workspace. Two at
/// once (a second cell, or an engineer's laptop, on the same LAN and prefix) would each send
/// plans the arm takes over in turn; one of another arm plans collisions for a base pose or tool
/// the arm does not have. Pure: times are passed in.
class PlannerWatch {
 public:
  /// `arm_model`: this driver's armModelId; `window_s`: how long a planner counts as present after
  /// its last heartbeat (the planner heartbeat timeout).
  PlannerWatch(double arm_model, double window_s) : arm_model_(arm_model), window_s_(window_s) {}

  /// A heartbeat of a planner process (`who`: its host and pid) at `now_s` (a monotonic clock),
  /// with its arm_model figure (NaN: the heartbeat has none, which is not checked) and whether it
  /// is stopping (its last). Returns "" if it counts as the heartbeat of the planner to follow,
  /// otherwise why not (for Driver::plannerHeartbeat).
  std::string heard(const std::string& who, double arm_model, bool stopping, double now_s);

 private:
  double arm_model_;
  double window_s_;
  std::map<std::string, double> last_s_;  ///< each planner heard within the window: its last heartbeat
};

}  // namespace depowder::robot
