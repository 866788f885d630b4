// The planner of a whole cell: keeps the latest pose, progress and arm state, decides when
// to plan (pose moved, phase changed, the cycle finished) and which part is next (one cycle
// per part in turn, as in the paper's two-cube demo; DONE parts are finished, LOST parts
// skipped and reported but still avoided), and holds when its inputs are missing or stale.
// The inputs are the LCM messages' contents; the node converts, this class validates.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "depowder/clock.hpp"
#include "depowder/planner/collision.hpp"
#include "depowder/planner/config.hpp"
#include "depowder/planner/plan.hpp"
#include "depowder/robot/kinematics.hpp"

namespace depowder::planner {

/// Values of part_pose_t's status.
enum class TrackStatus : std::int8_t { kWaiting = 0, kTracking = 1, kDegraded = 2, kLost = 3 };
/// Values of progress_t's status.
enum class ProgressStatus : std::int8_t { kOk = 0, kNoPose = 1, kNoPoints = 2, kNoContour = 3 };
const char* toString(ProgressStatus s);

struct PoseInput {
  std::string part;
  std::int64_t utime = 0;
  Pose T_cell_part = Pose::Identity();
  TrackStatus status = TrackStatus::kTracking;
  std::string status_reason;
};

struct ProgressInput {
  std::string part;
  std::int64_t utime = 0;
  Phase phase = Phase::kVacuumBuried;
  ProgressStatus status = ProgressStatus::kOk;
  std::string status_reason;
  double eta = 0;    ///< 0..1
  double h_pow = 0;  ///< m (used, and required finite, only with status kOk)
  double h_max = 0;  ///< m
  double h_min = 0;  ///< m
  Cloud contour;     ///< cell frame
};

struct RobotInput {
  std::int64_t utime = 0;
  robot::Joints q{};
  std::int64_t plan_id = -1;  ///< plan being executed (-1: none)
  int waypoint_index = 0;     ///< next waypoint of that plan
  bool idle = false;          ///< the driver has no plan (MODE_IDLE)
};

enum class InputStatus { kAccepted, kUnknownPart, kInvalidPose, kInvalidValue, kInvalidContour, kOutOfOrder };
const char* toString(InputStatus s);

struct InputResult {
  InputStatus status = InputStatus::kAccepted;
  std::string reason;  ///< why it was refused; for one accepted, what it changed beyond itself (or "")
  bool ok() const { return status == InputStatus::kAccepted; }
};

struct PartSpec {
  std::shared_ptr<const PartShape> shape;
  Pose T_cell_part_init = Pose::Identity();  ///< the printer's build layout (phase 1 pose)
};

/// One part as the planner sees it (for the heartbeat and the log).
struct PartReport {
  std::string name;
  Phase phase = Phase::kNone;  ///< from PROGRESS (kNone before the first)
  bool lost = false;           ///< the tracker reports LOST: skipped, avoided with lost_margin
  bool done = false;
  int cycles = 0;    ///< cycles planned on it
  std::string note;  ///< the last problem, e.g. "skipped: lost (fit failed)"
};

class CellPlanner {
 public:
  CellPlanner(std::vector<PartSpec> parts, const Box& box, std::shared_ptr<const robot::ArmConfig> arm,
              const PlannerConfig& config = {});
  ~CellPlanner();

  /// `arrival` is when the input arrived, us on a clock that only moves forward (the node's
  /// node::steadyUtime; a test's or an in-process run's own), for the far-ahead rule.
  ///
  /// A pose or progress older than the part's last is refused (kOutOfOrder). So is one more than
  /// kClockJumpBack behind the newest input (depowder/clock.hpp), unless the input before it was
  /// refused so and this one is not as far behind that one: two in a row mean the frames' clock
  /// went back. Then every pose, progress and time of the old clock is forgotten, the parts are
  /// planned afresh from this input on, and the result's reason says so. One that runs more than
  /// kClockJumpBack ahead of the newest input and the wall time since it arrived is refused too,
  /// unless the input before it was refused so and this one runs with it (runsAhead within
  /// kClockJumpBack): then the frames' clock jumped forward, and it is taken.
  InputResult onPose(const PoseInput& in, std::int64_t arrival);
  InputResult onProgress(const ProgressInput& in, std::int64_t arrival);
  /// The robot's clock going back dates the end of the running cycle anew.
  InputResult onRobot(const RobotInput& in);

  /// Decides. Returns a plan to publish, or nothing when the current plan stands. A hold
  /// (no waypoints) is returned once per distinct reason, not on every call. A running plan
  /// that nothing changed is re-sent every replan.refresh_s with newer frames: its remaining
  /// waypoints (from the driver's waypoint_index on), a new plan_id, reason "refresh: ...".
  std::optional<Plan> step();

  const std::vector<PartReport>& parts() const { return reports_; }
  /// True once every part is DONE (and the home move was planned).
  bool finished() const { return finished_; }
  const CollisionWorld& world() const;
  /// Times the frames' clock went back and the planning started over.
  std::int64_t clockRestarts() const { return clock_restarts_; }

 private:
  struct PartState;
  std::optional<Plan> hold(const std::string& reason, std::int64_t utime);
  std::optional<Plan> home(const std::string& why, std::int64_t utime);
  std::optional<Plan> emit(Plan plan);
  std::optional<Plan> refresh(std::int64_t utime);
  bool eligible(int i) const;
  bool cycleFinished() const;
  /// The clock rules for a pose or progress at `utime`, arriving at `arrival` (`what` of `part`):
  /// one far behind the newest input, or far ahead of it and the time since, is refused
  /// (kOutOfOrder), unless the input before it was refused so and this one runs with it. Then the
  /// result (accepted) says so; for a clock that went back, the old clock's inputs and times are
  /// forgotten.
  InputResult checkClock(const char* what, const std::string& part, std::int64_t utime, std::int64_t arrival);
  /// Takes `utime`, arriving at `arrival`, as the newest input's if it is.
  void takeNewest(std::int64_t utime, std::int64_t arrival);
  void updateWorld();
  /// Remembers the parts of the world as the active cycle was checked against them.
  void rememberWorld();
  /// Another part moved as far as would replan the active one (replan.translation or
  /// rotation_deg), or was lost or found, since the active cycle was checked: what is left of
  /// it is checked again, against every part but the active one. Returns the first contact
  /// ("waypoint N: what"), or "" if it is clear or nothing changed.
  std::string othersBlockTheCycle();
  /// The arm is within transition.direct_move of the active cycle's first waypoint, and the
  /// straight way there is clear.
  bool atCycleStart() const;
  /// Step 3b: part `i`'s phase 3 is still an undercut (vacuum loops below the part before the air
  /// blast) at tracked pose T and progress frame `utime`. When the undercut ends for loops that
  /// no longer lower the powder, `ended` says so ("; undercut ended: ...").
  bool undercuts(int i, const Pose& T, std::int64_t utime, std::string& ended);

  PlannerConfig config_;
  std::shared_ptr<const robot::ArmConfig> arm_;
  std::unique_ptr<CollisionWorld> world_;
  std::vector<PartState> states_;
  std::vector<PartReport> reports_;
  std::optional<RobotInput> robot_;
  std::int64_t newest_utime_ = 0;  ///< of the poses and progress taken (0: none since the start or the clock went back)
  std::int64_t newest_arrival_ = 0;         ///< when the input of newest_utime_ arrived (us)
  std::int64_t newest_progress_utime_ = 0;  ///< the last step of a frame's pipeline
  std::int64_t cycle_end_progress_utime_ = -1, cycle_end_robot_utime_ = -1;  ///< when the active cycle was seen done
  std::int64_t next_plan_id_ = 1;
  // The plan being executed.
  std::int64_t active_id_ = 0;
  std::size_t active_size_ = 0;
  std::vector<Waypoint> active_waypoints_;
  std::int64_t active_utime_ = 0;
  std::string active_reason_;
  std::string active_part_name_;
  Phase active_plan_phase_ = Phase::kNone;
  PlanStatus active_status_ = PlanStatus::kHold;
  int active_part_ = -1;
  Phase active_phase_ = Phase::kNone;
  Pose active_pose_ = Pose::Identity();
  double active_powder_ = 0;
  bool active_is_cycle_ = false;
  std::vector<std::pair<Pose, planner::PartState>> checked_world_;  ///< see rememberWorld
  std::string last_hold_;
  std::string home_reason_;                ///< why the last home move was planned ("" if none since the last cycle)
  std::int64_t emitted_robot_utime_ = -1;  ///< the driver's last ROBOT_STATE utime when the active plan went out
  std::string home_failed_;                ///< the reason of the last home move that could not be planned
  std::int64_t home_failed_utime_ = -1;    ///< newest input utime then (planned again after newer ones)
  bool finished_ = false;
  std::int64_t clock_restarts_ = 0;
  std::int64_t back_utime_ = -1;  ///< of the last input if it was refused as far behind the newest (-1: it was not)
  AheadWatch ahead_;              ///< the last input, if it was refused as far ahead
};

}  // namespace depowder::planner
