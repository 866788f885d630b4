#include "depowder/planner/cell_planner.hpp"

#include <cmath>
#include <cstdio>
#include <deque>
#include <stdexcept>

#include "depowder/clock.hpp"
#include "depowder/stats.hpp"

namespace depowder::planner {

const char* toString(ProgressStatus s) {
  switch (s) {
    case ProgressStatus::kOk:
      return "OK";
    case ProgressStatus::kNoPose:
      return "NO_POSE";
    case ProgressStatus::kNoPoints:
      return "NO_POINTS";
    case ProgressStatus::kNoContour:
      return "NO_CONTOUR";
  }
  return "?";
}

const char* toString(InputStatus s) {
  switch (s) {
    case InputStatus::kAccepted:
      return "ACCEPTED";
    case InputStatus::kUnknownPart:
      return "UNKNOWN_PART";
    case InputStatus::kInvalidPose:
      return "INVALID_POSE";
    case InputStatus::kInvalidValue:
      return "INVALID_VALUE";
    case InputStatus::kInvalidContour:
      return "INVALID_CONTOUR";
    case InputStatus::kOutOfOrder:
      return "OUT_OF_ORDER";
  }
  return "?";
}

struct CellPlanner::PartState {
  PartSpec spec;
  std::optional<PoseInput> pose;
  std::optional<ProgressInput> progress;
  double powder = std::nan("");                               ///< last h_pow from a progress message with a contour
  std::deque<std::pair<std::int64_t, double>> powder_window;  ///< the h_pow of the last kPowderWindow (utime, m)
  std::int64_t failed_utime = -1;         ///< newest input utime when planning last failed (retry after newer)
  bool blasting = false;                  ///< its air blast has begun (undercut done); until it leaves phase 3
  double undercut_mark = std::nan("");    ///< median powder when the undercut last lowered it half a layer...
  std::int64_t undercut_mark_utime = -1;  ///< ...at this frame
  double undercut_loop_s = 0;             ///< s its last undercut loop takes the nozzle (0: none yet)
  std::optional<Pose> still_pose;         ///< tracked pose the part has kept within the moving thresholds...
  std::int64_t still_utime = -1;          ///< ...since this frame, at most settle_s ago
  std::int64_t moved_utime = -1;          ///< the last frame it moved at (-1: not since tracking began)
  std::int64_t tracked_utime = -1;        ///< the last frame its pose was measured at (a PART_POSE not LOST)
};

namespace {

constexpr double kPi = 3.14159265358979323846;
double seconds(std::int64_t us) { return static_cast<double>(us) * 1e-6; }

/// The undercut's tests (CellPlanner::undercuts) take the median powder height of this span of
/// frames (us): 16 frames at 30 Hz.
constexpr std::int64_t kPowderWindow = 500000;

/// An input stamped outside the utimes taken (depowder/clock.hpp): every time the planner keeps is
/// a difference of two of them.
InputResult outOfRange(const std::string& what, std::int64_t utime) {
  return {InputStatus::kInvalidValue, what + " has " + utimeOutOfRange(utime)};
}

}  // namespace

CellPlanner::CellPlanner(std::vector<PartSpec> parts, const Box& box, std::shared_ptr<const robot::ArmConfig> arm,
                         const PlannerConfig& config)
    : config_(config), arm_(std::move(arm)) {
  if (!arm_) throw std::invalid_argument("CellPlanner needs an arm model");
  std::vector<std::shared_ptr<const PartShape>> shapes;
  for (PartSpec& p : parts) {
    if (!p.shape) throw std::invalid_argument("CellPlanner: part without a shape");
    shapes.push_back(p.shape);
    PartReport r;
    r.name = p.shape->name();
    reports_.push_back(r);
    PartState s;
    s.spec = std::move(p);
    states_.push_back(std::move(s));
  }
  world_ = std::make_unique<CollisionWorld>(std::move(shapes), box, config_.nozzle, config_.collision, arm_);
  updateWorld();
}

CellPlanner::~CellPlanner() = default;

const CollisionWorld& CellPlanner::world() const { return *world_; }

namespace {

template <class States>
int findPart(const States& states, const std::string& name) {
  for (std::size_t i = 0; i < states.size(); ++i)
    if (states[i].spec.shape->name() == name) return static_cast<int>(i);
  return -1;
}

}  // namespace

InputResult CellPlanner::onPose(const PoseInput& in, std::int64_t arrival) {
  const int i = findPart(states_, in.part);
  if (i < 0) return {InputStatus::kUnknownPart, "PART_POSE for unknown part '" + in.part + "'"};
  if (!isValidPose(in.T_cell_part, 1e-6))
    return {InputStatus::kInvalidPose,
            "PART_POSE of " + in.part + " is not a valid rigid transform (NaN or not orthonormal)"};
  if (!utimeInRange(in.utime)) return outOfRange("PART_POSE of " + in.part, in.utime);
  const InputResult clock = checkClock("PART_POSE", in.part, in.utime, arrival);
  if (!clock.ok()) return clock;
  PartState& s = states_[i];
  if (s.pose && in.utime < s.pose->utime)
    return {InputStatus::kOutOfOrder, "PART_POSE of " + in.part + " is older than the last one"};
  s.pose = in;
  if (in.status != TrackStatus::kLost) s.tracked_utime = in.utime;
  takeNewest(in.utime, arrival);
  // Motion watch (replan.settle_s) from the first tracked pose on: the jump from the printed pose
  // to the first ICP estimate is not a motion. The pose it is measured from is at most settle_s
  // old: a slow drift of the estimate is not a motion either.
  const ReplanConfig& rp = config_.replan;
  if (in.status == TrackStatus::kTracking || in.status == TrackStatus::kDegraded) {
    const bool moved = s.still_pose && (translationDistance(in.T_cell_part, *s.still_pose) > rp.moving_translation ||
                                        rotationAngle(in.T_cell_part.linear(), s.still_pose->linear()) >
                                            rp.moving_rotation_deg * kPi / 180);
    if (moved) s.moved_utime = in.utime;
    if (!s.still_pose || moved || seconds(in.utime - s.still_utime) > rp.settle_s) {
      s.still_pose = in.T_cell_part;
      s.still_utime = in.utime;
    }
  }
  return clock;
}

InputResult CellPlanner::onProgress(const ProgressInput& in, std::int64_t arrival) {
  const int i = findPart(states_, in.part);
  if (i < 0) return {InputStatus::kUnknownPart, "PROGRESS for unknown part '" + in.part + "'"};
  // Heights are only meaningful with a contour (the estimator sends NaN without one).
  if (!std::isfinite(in.eta) || (in.status == ProgressStatus::kOk &&
                                 (!std::isfinite(in.h_pow) || !std::isfinite(in.h_max) || !std::isfinite(in.h_min))))
    return {InputStatus::kInvalidValue, "PROGRESS of " + in.part + " has a non-finite eta or height"};
  if (!utimeInRange(in.utime)) return outOfRange("PROGRESS of " + in.part, in.utime);
  const int phase = static_cast<int>(in.phase);
  if (phase < 1 || phase > 4)
    return {InputStatus::kInvalidValue, "PROGRESS of " + in.part + " has phase " + std::to_string(phase) + " (1..4)"};
  // The contour lies on the powder in the build box (cell origin at the centre of its floor). A
  // point beyond its walls is no powder round the part (a wall's top in a crop wider than the
  // box, or a corrupt value: one 5e10 m away overflowed the loop's resampling): left out.
  const Box& box = world_->box();
  Cloud inside;
  inside.reserve(in.contour.size());
  for (const Point& p : in.contour) {
    if (!p.allFinite())
      return {InputStatus::kInvalidContour, "PROGRESS of " + in.part + " has a non-finite contour point"};
    if (std::abs(p.x()) <= 0.5 * box.size.x() + box.wall && std::abs(p.y()) <= 0.5 * box.size.y() + box.wall)
      inside.push_back(p);
  }
  const bool left_out = inside.size() < in.contour.size();
  const std::string outside = "contour points beyond the build box's walls left out";
  if (in.status == ProgressStatus::kOk && inside.size() < 3)
    return {InputStatus::kInvalidContour, "PROGRESS of " + in.part + " says OK but its contour has " +
                                              std::to_string(inside.size()) + " points" +
                                              (left_out ? " (" + outside + ")" : "")};
  const InputResult clock = checkClock("PROGRESS", in.part, in.utime, arrival);
  if (!clock.ok()) return clock;
  std::string note = clock.reason;
  PartState& s = states_[i];
  if (s.progress && in.utime < s.progress->utime)
    return {InputStatus::kOutOfOrder, "PROGRESS of " + in.part + " is older than the last one"};
  s.progress = in;
  s.progress->contour = std::move(inside);
  if (in.status == ProgressStatus::kOk) {
    s.powder = in.h_pow;
    s.powder_window.emplace_back(in.utime, in.h_pow);
    while (in.utime - s.powder_window.front().first > kPowderWindow) s.powder_window.pop_front();
  }
  takeNewest(in.utime, arrival);
  newest_progress_utime_ = std::max(newest_progress_utime_, in.utime);
  if (left_out) note += (note.empty() ? "" : "; ") + ("PROGRESS of " + in.part + ": " + outside);
  return {InputStatus::kAccepted, note};
}

InputResult CellPlanner::onRobot(const RobotInput& in) {
  for (double v : in.q)
    if (!std::isfinite(v)) return {InputStatus::kInvalidValue, "ROBOT_STATE has non-finite joints"};
  if (!utimeInRange(in.utime)) return outOfRange("ROBOT_STATE", in.utime);
  if (robot_ && cycle_end_robot_utime_ >= 0 && clockWentBack(robot_->utime, in.utime))
    cycle_end_robot_utime_ = in.utime;
  robot_ = in;
  if (active_is_cycle_ && cycle_end_robot_utime_ < 0 && cycleFinished()) {  // the cycle just ended (step 2a)
    cycle_end_progress_utime_ = newest_progress_utime_;
    cycle_end_robot_utime_ = in.utime;
  }
  return {};
}

InputResult CellPlanner::checkClock(const char* what, const std::string& part, std::int64_t utime,
                                    std::int64_t arrival) {
  const std::string said = what + (" of " + part);
  char buf[80];
  // Far ahead: one alone is a bad stamp, refused; the clock jumped forward when the input after
  // it runs with it.
  const std::int64_t ahead = newest_utime_ > 0 ? runsAhead(newest_utime_, newest_arrival_, utime, arrival) : 0;
  if (ahead > kClockJumpBack) {
    back_utime_ = -1;
    std::snprintf(buf, sizeof buf, " is %.1f s ahead of the newest input and the time since",
                  static_cast<double>(ahead) * 1e-6);
    if (!ahead_.confirms(utime, arrival))
      return {InputStatus::kOutOfOrder,
              said + buf + ": refused, unless the next input confirms that the frames' clock jumped forward"};
    return {InputStatus::kAccepted, said + buf + ", as was the one before it: the frames' clock jumped forward"};
  }
  ahead_.forget();
  if (newest_utime_ == 0 || !clockWentBack(newest_utime_, utime)) {
    back_utime_ = -1;
    return {};
  }
  // Far behind: alike, the clock went back when the input after it is as far behind and runs with
  // it (not itself far behind it).
  std::snprintf(buf, sizeof buf, " is %.1f s behind the newest input",
                static_cast<double>(behind(newest_utime_, utime)) * 1e-6);
  if (back_utime_ < 0 || clockWentBack(back_utime_, utime)) {
    back_utime_ = utime;
    return {InputStatus::kOutOfOrder,
            said + buf + ": refused, unless the next input confirms that the frames' clock went back"};
  }
  for (PartState& s : states_) {
    PartState fresh;
    fresh.spec = std::move(s.spec);
    s = std::move(fresh);
  }
  newest_utime_ = newest_progress_utime_ = active_utime_ = 0;
  cycle_end_progress_utime_ = cycle_end_robot_utime_ = home_failed_utime_ = -1;
  active_is_cycle_ = false;
  back_utime_ = -1;
  ++clock_restarts_;
  return {InputStatus::kAccepted, said + buf +
                                      ", as was the one before it: the frames' clock went back (a log played again, "
                                      "or the cameras restarted); planning starts over"};
}

void CellPlanner::takeNewest(std::int64_t utime, std::int64_t arrival) {
  if (utime <= newest_utime_) return;
  newest_utime_ = utime;
  newest_arrival_ = arrival;
}

void CellPlanner::updateWorld() {
  double powder_top = 0;
  for (std::size_t i = 0; i < states_.size(); ++i) {
    const PartState& s = states_[i];
    PartReport& r = reports_[i];
    r.phase = s.progress ? s.progress->phase : Phase::kNone;
    r.done = r.phase == Phase::kDone;
    // A LOST PART_POSE carries the last pose measured: like a missing one, that pose is used
    // until it is stale_s behind the newest frame (the nozzle coming down beside a part hides it
    // from one camera for a few frames), then the part is lost.
    r.lost = s.pose && s.pose->status == TrackStatus::kLost &&
             seconds(newest_utime_ - s.tracked_utime) > config_.replan.stale_s;
    if (r.lost) r.note = "skipped: lost" + (s.pose->status_reason.empty() ? "" : " (" + s.pose->status_reason + ")");
    // Phase 1 (and before any estimate): the part sits at its printed pose (paper Sec. III-B).
    const bool tracked = s.pose && r.phase != Phase::kNone && r.phase != Phase::kVacuumBuried;
    world_->setPart(i, tracked ? s.pose->T_cell_part : s.spec.T_cell_part_init,
                    r.lost ? planner::PartState::kLost : planner::PartState::kTracked);
    if (std::isfinite(s.powder)) powder_top = std::max(powder_top, s.powder);
  }
  world_->setPowderTop(std::min(powder_top, world_->box().size.z()));
}

void CellPlanner::rememberWorld() {
  checked_world_.clear();
  for (std::size_t i = 0; i < world_->numParts(); ++i)
    checked_world_.emplace_back(world_->partPose(i), world_->partState(i));
}

std::string CellPlanner::othersBlockTheCycle() {
  bool changed = checked_world_.size() != world_->numParts();
  for (std::size_t i = 0; i < world_->numParts() && !changed; ++i) {
    if (static_cast<int>(i) == active_part_) continue;
    const auto& [T, state] = checked_world_[i];
    const Pose& now = world_->partPose(i);
    changed = state != world_->partState(i) || translationDistance(now, T) > config_.replan.translation ||
              rotationAngle(now.linear(), T.linear()) > config_.replan.rotation_deg * kPi / 180;
  }
  if (!changed) return "";
  rememberWorld();
  const bool running = robot_ && robot_->plan_id == active_id_;
  const std::size_t from = running ? static_cast<std::size_t>(std::max(0, robot_->waypoint_index)) : 0;
  for (std::size_t k = from; k < active_waypoints_.size(); ++k)
    if (const Contact c = world_->checkArm(active_waypoints_[k].q, CheckOptions(false, true, active_part_)))
      return "waypoint " + std::to_string(k) + ": " + c.what;
  return "";
}

bool CellPlanner::atCycleStart() const {
  if (!robot_ || active_waypoints_.empty()) return false;
  const Waypoint now = atJoints(*arm_, robot_->q);
  const Waypoint& first = active_waypoints_.front();
  return translationDistance(now.T_cell_nozzle, first.T_cell_nozzle) <= config_.transition.direct_move &&
         edgeFree(*world_, now, first, config_);
}

bool CellPlanner::eligible(int i) const {
  const PartState& s = states_[i];
  const PartReport& r = reports_[i];
  if (!s.progress || r.done || r.lost) return false;
  return s.failed_utime < 0 || s.progress->utime > s.failed_utime;
}

bool CellPlanner::cycleFinished() const {
  return robot_ && robot_->plan_id == active_id_ &&
         (robot_->waypoint_index >= static_cast<int>(active_size_) || robot_->idle);
}

std::optional<Plan> CellPlanner::emit(Plan plan) {
  plan.plan_id = next_plan_id_++;
  active_id_ = plan.plan_id;
  emitted_robot_utime_ = robot_ ? robot_->utime : -1;
  active_size_ = plan.waypoints.size();
  active_waypoints_ = plan.waypoints;
  active_utime_ = plan.utime;
  cycle_end_progress_utime_ = cycle_end_robot_utime_ = -1;
  active_reason_ = plan.reason.rfind("refresh: ", 0) == 0 ? plan.reason : "refresh: " + plan.reason;
  active_part_name_ = plan.part;
  active_plan_phase_ = plan.phase;
  active_status_ = plan.status;
  if (plan.status != PlanStatus::kHold) last_hold_.clear();
  return plan;
}

std::optional<Plan> CellPlanner::refresh(std::int64_t utime) {
  if (active_waypoints_.empty() || !robot_) return std::nullopt;
  if (static_cast<double>(utime - active_utime_) * 1e-6 < config_.replan.refresh_s) return std::nullopt;
  // The driver runs our plan: re-send what is left of it. It runs another one (it refused ours,
  // e.g. one that came before it had heard our heartbeat): re-send ours whole.
  const bool running = robot_->plan_id == active_id_;
  const std::size_t from = running ? static_cast<std::size_t>(std::max(0, robot_->waypoint_index)) : 0;
  if (from >= active_waypoints_.size()) return std::nullopt;
  Plan plan;
  plan.status = active_status_;
  plan.reason = active_reason_;
  plan.part = active_part_name_;
  plan.phase = active_plan_phase_;
  plan.utime = utime;
  plan.waypoints.assign(active_waypoints_.begin() + static_cast<std::ptrdiff_t>(from), active_waypoints_.end());
  return emit(std::move(plan));
}

std::optional<Plan> CellPlanner::hold(const std::string& reason, std::int64_t utime) {
  // Nothing to plan, with a part in the arm's margins (toppled or pushed onto the nozzle): a cycle
  // would have begun with the way out of it (escape); the home move does, then holds.
  if (robot_) {
    if (const Contact c = world_->checkArm(robot_->q); c && c.part >= 0) {
      const std::string why = reason.rfind("hold: ", 0) == 0 ? reason.substr(6) : reason;
      return home(why + "; out of the margins of " + world_->part(static_cast<std::size_t>(c.part)).name() + " first",
                  utime);
    }
  }
  active_is_cycle_ = false;
  if (reason == last_hold_) return std::nullopt;
  last_hold_ = reason;
  Plan plan;
  plan.status = PlanStatus::kHold;
  plan.reason = reason;
  plan.utime = utime;
  return emit(std::move(plan));
}

std::optional<Plan> CellPlanner::home(const std::string& why, std::int64_t utime) {
  active_is_cycle_ = false;
  if (home_reason_ == why) return refresh(utime);
  // A home move that could not be planned is planned again on newer frames (a part or the arm
  // may have moved out of the way), as a failed cycle is; said once while it keeps failing.
  if (home_failed_utime_ >= newest_utime_) return std::nullopt;
  const robot::Joints q = robot_ ? robot_->q : arm_->q_home;
  Plan plan = planHome(*world_, q, config_, why);
  plan.utime = utime;
  if (plan.status == PlanStatus::kHome) {
    home_reason_ = why;
    home_failed_utime_ = -1;
    home_failed_.clear();
    return emit(std::move(plan));
  }
  home_failed_utime_ = newest_utime_;
  if (plan.reason == home_failed_ && !plan.hasWaypoints()) return std::nullopt;
  home_failed_ = plan.reason;
  return emit(std::move(plan));
}

bool CellPlanner::undercuts(int i, const Pose& T, std::int64_t utime, std::string& ended) {
  // Undercut (vacuum.undercut): before the air blast, vacuum loops until the powder beside the
  // part is down to the loops' floor below its bottom (one layer of slack: the powder next to the
  // nozzle stays a little higher than under it). Once the air blast has begun it goes on (the
  // measured height hovers about the threshold) until phase 3 ends. Loops that no longer lower it
  // (the nozzle cannot reach all round a toppled part: the measured height stayed a few mm over
  // the threshold for good, and the air blast never began) give way to the air blast once it has
  // fallen less than half a layer in the time kUndercutStalls loops take. Timed, not counted: on a
  // toppled part the loops are planned anew for a jittering pose before they end, and a run went
  // 175 s with 4 loops ended. Both tests take the median h_pow of the last kPowderWindow
  // (onProgress), not the last: h_pow is one frame's, a glitched pose can put its band on the
  // dug pit, and beside a toppled pipe it scattered by 0.9 mm (sd, within 2 s; up to 5 mm apart).
  constexpr int kUndercutStalls = 3;
  PartState& s = states_[i];
  const VacuumConfig& vc = config_.vacuum;
  if (s.blasting || vc.undercut <= 0) return false;
  std::vector<double> window;
  for (const auto& [frame_utime, h_pow] : s.powder_window) window.push_back(h_pow);
  const double powder = interpolatedPercentile(std::move(window), 0.5);  // NaN before the first
  if (!std::isfinite(powder) || powder <= loopFloor(*s.spec.shape, T, vc) + vc.layer_depth) return false;
  if (!(powder >= s.undercut_mark - 0.5 * vc.layer_depth)) {  // the first, or half a layer lower
    s.undercut_mark = powder;
    s.undercut_mark_utime = utime;
  }
  const double stalled_s = seconds(utime - s.undercut_mark_utime);
  if (s.undercut_loop_s <= 0 || stalled_s <= kUndercutStalls * s.undercut_loop_s) return true;
  char buf[200];
  std::snprintf(buf, sizeof buf,
                "; undercut ended: the powder fell less than %.1f mm in %.0f s, the time of %d loops (at %.3f m)",
                500 * vc.layer_depth, stalled_s, kUndercutStalls, powder);
  ended = buf;
  return false;
}

std::optional<Plan> CellPlanner::step() {
  updateWorld();
  // 1. Finished? Every part done: go home once.
  bool all_done = !states_.empty();
  for (const PartReport& r : reports_) all_done = all_done && r.done;
  if (all_done) {
    finished_ = true;
    return home("all parts done", newest_utime_);
  }
  finished_ = false;

  // 1b. A part on the move (toppling, pushed): away from it until it keeps still (settle_s).
  if (config_.replan.settle_s > 0) {
    std::string moving;
    for (std::size_t i = 0; i < states_.size(); ++i)
      if (states_[i].moved_utime >= 0 && seconds(newest_utime_ - states_[i].moved_utime) < config_.replan.settle_s)
        moving += (moving.empty() ? "" : ", ") + reports_[i].name;
    if (!moving.empty()) return home("moving: " + moving + "; waiting until still", newest_utime_);
  }

  // 2. Which part: stay on the active one until its cycle finishes, then the others in turn.
  const bool cycle_done = active_is_cycle_ && cycleFinished();
  // 2a. The next cycle is planned on the first estimates that come after the last one ended, not
  //     on those it ran on (up to a frame older): the plan then reflects the newest depth frame
  //     (the depth -> NOZZLE_PLAN latency), for at most kNextFrameWait of robot time idle. The
  //     cycle's end is recorded by onRobot, the one place it can happen.
  constexpr std::int64_t kNextFrameWait = 100000;  // us: three camera frames
  if (cycle_done && newest_progress_utime_ <= cycle_end_progress_utime_ &&
      robot_->utime - cycle_end_robot_utime_ < kNextFrameWait)
    return std::nullopt;
  const bool continuing = active_is_cycle_ && !cycle_done && active_part_ >= 0 && eligible(active_part_);
  std::vector<int> candidates;
  if (continuing) {
    candidates.push_back(active_part_);
  } else {
    const int n = static_cast<int>(states_.size());
    for (int k = 1; k <= n; ++k) {
      const int i = (active_part_ + k + n) % n;
      if (eligible(i)) candidates.push_back(i);
    }
  }
  if (candidates.empty()) {
    std::string lost, waiting;
    bool others = false;  // neither done nor lost: their next estimates may make them eligible again
    for (std::size_t i = 0; i < states_.size(); ++i) {
      if (reports_[i].done) continue;
      if (reports_[i].lost)
        lost += (lost.empty() ? "" : ", ") + reports_[i].name;
      else
        others = true;
      if (!states_[i].progress) waiting += (waiting.empty() ? "" : ", ") + reports_[i].name;
    }
    if (!waiting.empty()) return hold("hold: no PROGRESS yet for " + waiting, newest_utime_);
    if (!lost.empty() && !others) return home("every remaining part is lost: " + lost, newest_utime_);
    return hold("hold: no part can be planned until new estimates arrive", newest_utime_);
  }

  std::string first_problem;
  for (const int part : candidates) {
    PartState& s = states_[part];
    PartReport& report = reports_[part];
    const ProgressInput& progress = *s.progress;
    Phase phase = progress.phase;

    // 3. Inputs: phases 2 and 3 need a fresh tracked pose; phase 1 uses the printed pose.
    std::int64_t utime = progress.utime;
    Pose T = s.spec.T_cell_part_init;
    std::string problem;
    if (phase != Phase::kVacuumBuried) {
      if (!s.pose) {
        problem = "hold: no PART_POSE for " + report.name;
      } else if (const double lag = seconds(newest_utime_ - s.pose->utime); lag > config_.replan.stale_s) {
        char buf[64];
        std::snprintf(buf, sizeof(buf), " is stale (%.1f s behind)", lag);
        problem = "hold: PART_POSE of " + report.name + buf;
      } else {
        T = s.pose->T_cell_part;
        utime = std::max(utime, s.pose->utime);
      }
    }
    if (!problem.empty()) {
      report.note = problem;
      if (first_problem.empty()) first_problem = problem;
      continue;
    }

    // 3b. Undercut: phase 3 vacuums on below the part until the powder beside it is down.
    std::string undercut_ended;
    if (phase != Phase::kAirBlast) {
      s.blasting = false;
      s.undercut_mark = std::nan("");
    }
    const bool undercutting = phase == Phase::kAirBlast && undercuts(part, T, progress.utime, undercut_ended);
    if (undercutting) phase = Phase::kVacuumTracked;

    // 4. Plan only when something changed: a finished cycle, a new phase, a moved pose.
    const bool same = continuing && phase == active_phase_;
    const bool moved = translationDistance(T, active_pose_) > config_.replan.translation ||
                       rotationAngle(T.linear(), active_pose_.linear()) > config_.replan.rotation_deg * kPi / 180;
    // The driver checks no collision: another part that moved into the rest of the cycle
    // (toppled, pushed) has it planned anew, with the way out of it (escape) if need be.
    const std::string blocked = same && !moved ? othersBlockTheCycle() : "";
    // The driver dropped the cycle (an ESTOP reset, a restart): re-sent whole, its first waypoint
    // would be joined by a straight line from wherever the arm stopped, checked by nobody. Unless
    // the arm is still where the cycle begins, it is planned anew from there. A driver still
    // running the plan before ours has not dropped it yet: it takes a plan over within a cycle or
    // two, or once it has braked on the running one (under 0.1 s from the nozzle's top speed). Each
    // refresh was once taken for a drop and the cycle started over, again and again.
    constexpr std::int64_t kTakeOver = 200000;  // us of the driver's clock
    const bool dropped = same && !moved && robot_ && robot_->plan_id != active_id_ &&
                         (emitted_robot_utime_ < 0 || robot_->utime - emitted_robot_utime_ > kTakeOver) &&
                         !atCycleStart();
    if (same && !moved && blocked.empty() && !dropped) return refresh(utime);

    // 5. Build the cycle. A pose-triggered regeneration keeps the loop's layer.
    CycleRequest request;
    request.part = static_cast<std::size_t>(part);
    request.phase = phase;
    request.q_now = robot_ ? robot_->q : arm_->q_home;
    if (progress.status == ProgressStatus::kOk) {
      request.contour = progress.contour;
    } else {
      request.no_contour = std::string("progress ") + toString(progress.status) +
                           (progress.status_reason.empty() ? "" : ": " + progress.status_reason);
    }
    if (same) {
      // Keep the loop's layer, unless the powder is already lower than it (regenerations for a
      // jittering pose can come faster than a loop finishes: the layer must still follow the powder).
      request.powder_height = std::isfinite(s.powder) ? std::min(active_powder_, s.powder) : active_powder_;
    } else if (std::isfinite(s.powder)) {
      request.powder_height = s.powder;
    } else {
      // No contour height yet: Eq. 2 inverted with the part's heights at this pose.
      const HeightRange hr = partHeights(*s.spec.shape, T);
      request.powder_height = hr.max - progress.eta * (hr.max - hr.min);
      request.no_contour += "; powder height from eta";
    }
    Plan plan = planCycle(*world_, request, config_);
    plan.utime = utime;
    if (undercutting) plan.reason = "undercut: " + plan.reason;  // a vacuum plan in phase 3 (depowder-monitor)
    if (!robot_ && !plan.hasWaypoints()) plan.reason += " (planned from the arm's home joints: no ROBOT_STATE yet)";
    if (!blocked.empty())
      plan.reason = "another part in the cycle's way (" + blocked + "), planned anew: " + plan.reason;
    if (dropped) plan.reason = "the driver dropped the cycle away from its start, planned anew: " + plan.reason;
    plan.reason += undercut_ended;
    if (!plan.hasWaypoints()) {
      s.failed_utime = newest_utime_;
      report.note = plan.reason;
      if (first_problem.empty()) first_problem = plan.reason;
      continue;
    }
    if (!same) ++report.cycles;
    if (undercutting && !same) s.undercut_loop_s = travelSeconds(plan.waypoints);
    s.failed_utime = -1;
    if (phase == Phase::kAirBlast) s.blasting = true;
    report.note.clear();
    active_part_ = part;
    active_phase_ = phase;
    active_pose_ = T;
    active_powder_ = request.powder_height;
    active_is_cycle_ = true;
    home_reason_.clear();
    home_failed_.clear();
    home_failed_utime_ = -1;
    rememberWorld();
    return emit(std::move(plan));
  }
  return hold(first_problem, newest_utime_);
}

}  // namespace depowder::planner
