#include "depowder/robot/trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace depowder::robot {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

double maxAbsDiff(const Joints& a, const Joints& b) {
  double m = 0;
  for (int i = 0; i < 6; ++i) m = std::max(m, std::abs(a[i] - b[i]));
  return m;
}

Joints lerp(const Joints& a, const Joints& b, double t) {
  Joints q;
  for (int i = 0; i < 6; ++i) q[i] = a[i] + t * (b[i] - a[i]);
  return q;
}

}  // namespace

bool Workspace::contains(const Eigen::Vector3d& p, double margin) const {
  return p.allFinite() && (p.array() >= min.array() - margin).all() && (p.array() <= max.array() + margin).all();
}

const char* toString(PlanStatus s) {
  switch (s) {
    case PlanStatus::Accepted:
      return "accepted";
    case PlanStatus::Clipped:
      return "accepted with speeds clipped";
    case PlanStatus::Empty:
      return "empty (stop and hold)";
    case PlanStatus::InvalidWaypoint:
      return "invalid waypoint";
    case PlanStatus::OutsideWorkspace:
      return "outside the workspace";
    case PlanStatus::Unreachable:
      return "unreachable";
    case PlanStatus::JointJump:
      return "joint jump";
  }
  return "?";
}

// ---- preparing a plan ---------------------------------------------------------------------------

PreparedPlan preparePlan(const ArmConfig& arm, const TrajectoryConfig& cfg, const Workspace& workspace,
                         const Plan& plan, const Joints& q_start, int from_waypoint) {
  PreparedPlan out;
  out.id = plan.id;
  out.utime = plan.utime;
  out.first_waypoint = std::max(0, from_waypoint);
  const int n = static_cast<int>(plan.waypoints.size());
  if (out.first_waypoint >= n) {
    out.status = PlanStatus::Empty;
    out.reason = "no waypoints";
    return out;
  }
  auto refuse = [&](PlanStatus s, int i, const std::string& why) {
    out.status = s;
    out.bad_waypoint = i;
    out.reason = "waypoint " + std::to_string(i) + ": " + why;
    out.points.clear();
    return out;
  };

  // Validate every waypoint first: nothing of a bad plan is executed.
  std::vector<double> speeds(n);
  for (int i = out.first_waypoint; i < n; ++i) {
    const PlanWaypoint& w = plan.waypoints[i];
    if (!isValidPose(w.T_cell_nozzle, 1e-6)) return refuse(PlanStatus::InvalidWaypoint, i, "invalid pose");
    if (!std::isfinite(w.speed) || w.speed <= 0)
      return refuse(PlanStatus::InvalidWaypoint, i, "speed must be a positive number of m/s");
    if (w.tool != Tool::kOff && w.tool != Tool::kVacuum && w.tool != Tool::kAir)
      return refuse(PlanStatus::InvalidWaypoint, i, "unknown tool");
    if (!workspace.contains(w.T_cell_nozzle.translation()))
      return refuse(PlanStatus::OutsideWorkspace, i, "nozzle position outside the workspace box");
    speeds[i] = w.speed;
    if (w.speed > cfg.max_nozzle_speed) {
      speeds[i] = cfg.max_nozzle_speed;
      ++out.clipped;
    }
  }

  // Walk the Cartesian path in short steps, IK nearest the previous solution.
  Pose T_prev = forwardNozzle(arm, q_start);
  Joints q_prev = q_start;
  // If the arm starts outside the workspace (e.g. after a manual move), the lead-in to the
  // first waypoint may pass outside; everything after it must be inside.
  const bool start_inside = workspace.contains(T_prev.translation());
  for (int i = out.first_waypoint; i < n; ++i) {
    const Pose& T_goal = plan.waypoints[i].T_cell_nozzle;
    const bool check = start_inside || i > out.first_waypoint;
    const Eigen::Vector3d p0 = T_prev.translation(), p1 = T_goal.translation();
    const Eigen::Quaterniond r0(T_prev.linear()), r1(T_goal.linear());
    const double dist = (p1 - p0).norm();
    const double angle = rotationAngle(T_prev.linear(), T_goal.linear());
    const int steps = std::max({1, static_cast<int>(std::ceil(dist / cfg.cartesian_step - 1e-9)),
                                static_cast<int>(std::ceil(angle / cfg.rotation_step - 1e-9))});
    Eigen::Vector3d p_last = p0;
    Eigen::Matrix3d R_last = T_prev.linear();
    for (int k = 1; k <= steps; ++k) {
      const double t = static_cast<double>(k) / steps;
      Pose T = T_goal;
      if (k < steps) {
        T.linear() = r0.slerp(t, r1).toRotationMatrix();
        T.translation() = p0 + t * (p1 - p0);
      }
      const auto q = inverseNozzle(arm, T, q_prev);
      if (!q) return refuse(PlanStatus::Unreachable, i, "no IK solution within the joint limits on the way to it");
      if (maxAbsDiff(*q, q_prev) > cfg.max_joint_jump)
        return refuse(PlanStatus::JointJump, i,
                      "a joint would jump by " + std::to_string(maxAbsDiff(*q, q_prev)) +
                          " rad between IK points (configuration change)");
      if (check) {
        const Eigen::Vector3d mid = forwardNozzle(arm, lerp(q_prev, *q, 0.5)).translation();
        if (!workspace.contains(T.translation()) || !workspace.contains(mid))
          return refuse(PlanStatus::OutsideWorkspace, i, "the path to it leaves the workspace box");
      }
      PathPoint pt;
      pt.q = *q;
      pt.speed = speeds[i];
      pt.cart_step = (T.translation() - p_last).norm();
      pt.rot_step = rotationAngle(R_last, T.linear());
      pt.tool = plan.waypoints[i].tool;
      pt.waypoint = i - out.first_waypoint;
      out.points.push_back(pt);
      p_last = T.translation();
      R_last = T.linear();
      q_prev = *q;
    }
    T_prev = T_goal;
  }
  out.status = out.clipped > 0 ? PlanStatus::Clipped : PlanStatus::Accepted;
  if (out.clipped > 0)
    out.reason =
        std::to_string(out.clipped) + " waypoint speed(s) clipped to " + std::to_string(cfg.max_nozzle_speed) + " m/s";
  return out;
}

// ---- the generator --------------------------------------------------------------------------------

TrajectoryGenerator::TrajectoryGenerator(ArmConfig arm, TrajectoryConfig cfg)
    : arm_(std::move(arm)), cfg_(std::move(cfg)) {
  reset(arm_.q_home);
}

void TrajectoryGenerator::reset(const Joints& q) {
  segments_.clear();
  segment_ = 0;
  s_ = 0;
  speed_ = 0;
  stopping_ = false;
  finished_ = false;
  pending_ = false;
  plan_id_ = -1;
  waypoint_offset_ = 0;
  hold_q_ = q;
  last_q_ = q;
  tool_ = Tool::kOff;
  sample_ = TrajectorySample();
  sample_.q = q;
}

void TrajectoryGenerator::setPlan(const PreparedPlan& plan) {
  if (plan.status == PlanStatus::Empty) {
    stop();
    plan_id_ = plan.id;
    return;
  }
  if (!plan.usable()) return;
  pending_plan_ = plan;
  pending_ = true;
}

void TrajectoryGenerator::stop() {
  pending_ = false;
  if (hasPath() || speed_ > 0) stopping_ = true;
  tool_ = Tool::kOff;
}

double TrajectoryGenerator::brakingTime() const {
  if (!hasPath() || speed_ <= 0) return 0.0;
  // Braking may run into later segments with a lower acceleration limit: use the lowest ahead
  // within the braking distance at the current segment's rate (doubled as a margin).
  double a = segments_[segment_].amax;
  double dist = speed_ * speed_ / a, left = segments_[segment_].length - s_;
  for (std::size_t k = segment_ + 1; k < segments_.size() && left < 2 * dist; ++k) {
    a = std::min(a, segments_[k].amax);
    left += segments_[k].length;
  }
  // advance() brakes by a * cycle a step, so the stop ends on a whole cycle.
  return std::ceil(speed_ / (a * cfg_.cycle_s) - 1e-9) * cfg_.cycle_s;
}

TrajectoryGenerator::Segment TrajectoryGenerator::makeSegment(const Joints& a, const Joints& b,
                                                              const PathPoint& to) const {
  Segment s;
  s.q0 = a;
  for (int i = 0; i < 6; ++i) s.dq[i] = b[i] - a[i];
  // Path units: time at full (scaled) joint speed, so path speed 1 = the slowest-to-finish
  // joint at its limit and every joint within its own.
  for (int i = 0; i < 6; ++i) s.length = std::max(s.length, std::abs(s.dq[i]) / (arm_.qd_max[i] * cfg_.velocity_scale));
  if (s.length <= 0) return s;
  for (int i = 0; i < 6; ++i) s.dir[i] = s.dq[i] / s.length;
  s.vmax = 1.0;
  // Nozzle speed and rotation rate limits (the step is short, so its chord is its length).
  if (to.cart_step > 1e-12) s.vmax = std::min(s.vmax, to.speed * s.length / to.cart_step);
  if (to.rot_step > 1e-12) s.vmax = std::min(s.vmax, cfg_.max_nozzle_rotation_speed * s.length / to.rot_step);
  s.amax = kInf;
  for (int i = 0; i < 6; ++i) {
    if (std::abs(s.dir[i]) > 1e-12)
      s.amax = std::min(s.amax, arm_.qdd_max[i] * cfg_.acceleration_scale / std::abs(s.dir[i]));
  }
  return s;
}

double TrajectoryGenerator::junctionLimit(const Joints& a, const Joints& b) const {
  // Passing a corner at path speed v changes joint i's velocity by v |a_i - b_i| within one
  // cycle; allow a quarter of the acceleration budget for that (the rest is the path's own).
  double v = kInf;
  for (int i = 0; i < 6; ++i) {
    const double d = std::abs(a[i] - b[i]);
    if (d > 1e-12) v = std::min(v, 0.25 * arm_.qdd_max[i] * cfg_.acceleration_scale * cfg_.cycle_s / d);
  }
  return v;
}

std::vector<TrajectoryGenerator::Segment> TrajectoryGenerator::buildSegments(const Joints& q_from,
                                                                             const PreparedPlan& plan,
                                                                             double* v_start_max) const {
  std::vector<Segment> segs;
  Joints a = q_from;
  for (const PathPoint& p : plan.points) {
    Segment s = makeSegment(a, p.q, p);
    s.tool = p.tool;
    s.waypoint = p.waypoint;
    if (s.length <= 1e-12) {
      // Coincident point: only its tool and waypoint index matter.
      if (!segs.empty()) {
        segs.back().tool = p.tool;
        segs.back().waypoint = p.waypoint;
      }
      continue;
    }
    segs.push_back(s);
    a = p.q;
  }
  // Backward pass: the fastest speed at each segment's end from which everything after it can
  // still be done, ending at rest.
  double v_next_start = 0;  // speed allowed at the start of the segment after this one
  for (std::size_t k = segs.size(); k-- > 0;) {
    Segment& s = segs[k];
    double v = (k + 1 == segs.size()) ? 0.0 : v_next_start;
    if (k + 1 < segs.size()) {
      v = std::min({v, junctionLimit(s.dir, segs[k + 1].dir), s.vmax, segs[k + 1].vmax});
    }
    s.v_end = v;
    v_next_start = std::min(s.vmax, std::sqrt(v * v + 2 * s.amax * s.length));
  }
  *v_start_max = segs.empty() ? 0.0 : v_next_start;
  return segs;
}

void TrajectoryGenerator::tryTakePendingPlan() {
  if (!pending_) return;
  const Joints q_now = position();
  double v_start_max = 0;
  std::vector<Segment> segs = buildSegments(q_now, pending_plan_, &v_start_max);
  double limit = v_start_max;
  if (hasPath() && !segs.empty()) limit = std::min(limit, junctionLimit(segments_[segment_].dir, segs[0].dir));
  if (segs.empty()) limit = 0;
  if (speed_ > limit + 1e-12) {
    // Brake on the current path until the new one can take over without a jump.
    stopping_ = true;
    return;
  }
  segments_ = std::move(segs);
  segment_ = 0;
  s_ = 0;
  stopping_ = false;
  finished_ = segments_.empty();
  hold_q_ = q_now;
  plan_id_ = pending_plan_.id;
  waypoint_offset_ = pending_plan_.first_waypoint;
  last_waypoint_ = pending_plan_.points.empty() ? 0 : pending_plan_.points.back().waypoint;
  if (!segments_.empty()) tool_ = segments_[0].tool;
  if (segments_.empty() && !pending_plan_.points.empty()) tool_ = pending_plan_.points.back().tool;
  if (segments_.empty()) speed_ = 0;
  pending_ = false;
}

Joints TrajectoryGenerator::position() const {
  if (!hasPath()) return hold_q_;
  const Segment& s = segments_[segment_];
  return lerp(s.q0,
              {s.q0[0] + s.dq[0], s.q0[1] + s.dq[1], s.q0[2] + s.dq[2], s.q0[3] + s.dq[3], s.q0[4] + s.dq[4],
               s.q0[5] + s.dq[5]},
              s_ / s.length);
}

void TrajectoryGenerator::advance(double dt) {
  int guard = 0;
  while (dt > 1e-12 && hasPath() && ++guard < 10000) {
    const Segment& seg = segments_[segment_];
    const double a = seg.amax;
    const double v = speed_;
    const double d = seg.length - s_;
    double v_new;
    if (stopping_) {
      v_new = std::max(0.0, v - a * dt);
    } else {
      // The fastest speed after this step from which the segment end can still be reached at
      // v_end with deceleration a (discrete form of v^2 <= v_end^2 + 2 a d).
      const double c = seg.v_end * seg.v_end + 2 * a * d - a * v * dt;
      const double v_allow = c > 0 ? 0.5 * (-a * dt + std::sqrt(a * a * dt * dt + 4 * c)) : 0.0;
      v_new = std::min({seg.vmax, v + a * dt, v_allow});
      v_new = std::max({v_new, v - a * dt, 0.0});
    }
    const double ds = 0.5 * (v + v_new) * dt;
    if (ds < d) {
      s_ += ds;
      speed_ = v_new;
      if (stopping_ && speed_ <= 0) {
        // Controlled stop done: hold here.
        hold_q_ = position();
        segments_.clear();
        segment_ = 0;
        s_ = 0;
        stopping_ = false;
      }
      return;
    }
    // The segment ends within this step: time used to reach its end, speed there.
    const double avg = 0.5 * (v + v_new);
    const double t_used = avg > 1e-12 ? std::min(dt, d / avg) : dt;
    speed_ = v + (v_new - v) * (t_used / dt);
    hold_q_ = {seg.q0[0] + seg.dq[0], seg.q0[1] + seg.dq[1], seg.q0[2] + seg.dq[2],
               seg.q0[3] + seg.dq[3], seg.q0[4] + seg.dq[4], seg.q0[5] + seg.dq[5]};
    dt -= t_used;
    ++segment_;
    s_ = 0;
    if (!hasPath()) {
      speed_ = 0;
      stopping_ = false;
      finished_ = true;
      return;
    }
    tool_ = stopping_ ? Tool::kOff : segments_[segment_].tool;
  }
}

TrajectorySample TrajectoryGenerator::step() {
  tryTakePendingPlan();
  advance(cfg_.cycle_s);
  TrajectorySample s;
  s.q = position();
  for (int i = 0; i < 6; ++i) s.qd[i] = (s.q[i] - last_q_[i]) / cfg_.cycle_s;
  last_q_ = s.q;
  s.tool = tool_;
  s.plan_id = plan_id_;
  s.moving = speed_ > 0 || hasPath();
  if (plan_id_ >= 0) {
    if (hasPath())
      s.waypoint_index = waypoint_offset_ + segments_[segment_].waypoint;
    else
      s.waypoint_index = finished_ ? waypoint_offset_ + last_waypoint_ + 1 : -1;
  }
  sample_ = s;
  return s;
}

}  // namespace depowder::robot
