#include "depowder/robot/safety.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iterator>
#include <string>

#include "depowder/clock.hpp"
#include "depowder/digest.hpp"

namespace depowder::robot {

CommandLimiter::CommandLimiter(ArmConfig arm, double cycle_s, double tolerance)
    : arm_(std::move(arm)), dt_(cycle_s), tol_(tolerance) {
  reset(arm_.q_home);
}

void CommandLimiter::reset(const Joints& q) {
  q_ = q;
  v_ = {};
}

CommandLimiter::Result CommandLimiter::apply(const Joints& target) {
  Result r;
  for (int i = 0; i < 6; ++i) {
    // An arm found outside the limits (the driver refuses to enable there) may move back in,
    // never further out, and never in one step: the range is widened to hold where it is.
    const double lo = std::min(arm_.q_min[i], q_[i]), hi = std::max(arm_.q_max[i], q_[i]);
    double t = target[i];
    if (!std::isfinite(t)) {
      t = q_[i];
      r.clipped_position = true;
    }
    if (t < lo || t > hi) {
      t = std::clamp(t, lo, hi);
      r.clipped_position = true;
    }
    double v = (t - q_[i]) / dt_;
    const double vmax = arm_.qd_max[i] * tol_;
    const double dv = arm_.qdd_max[i] * tol_ * dt_;
    if (std::abs(v) > vmax) {
      v = std::clamp(v, -vmax, vmax);
      r.clipped_speed = true;
    }
    if (v > v_[i] + dv || v < v_[i] - dv) {
      v = std::clamp(v, v_[i] - dv, v_[i] + dv);
      r.clipped_acceleration = true;
    }
    // The limited step must itself stay within the joint limits.
    double q = std::clamp(q_[i] + v * dt_, lo, hi);
    v_[i] = (q - q_[i]) / dt_;
    q_[i] = q;
    r.q[i] = q;
  }
  return r;
}

const char* toString(StopReason r) {
  switch (r) {
    case StopReason::None:
      return "none";
    case StopReason::PlanStale:
      return "plan stale";
    case StopReason::ClockAhead:
      return "plan ahead of this host's clock";
    case StopReason::PlannerMismatch:
      return "not the planner to follow";
    case StopReason::HeartbeatLost:
      return "planner heartbeat lost";
    case StopReason::Workspace:
      return "nozzle outside the workspace";
  }
  return "?";
}

SafetyVerdict checkNewPlan(const SafetyConfig& cfg, std::int64_t now_utime, std::int64_t plan_utime,
                           double heartbeat_age_s) {
  SafetyVerdict v;
  char buf[256];
  const double age = secondsBetween(now_utime, plan_utime);
  if (plan_utime <= 0) {
    v.stop = StopReason::PlanStale;
    v.reason = "plan has no source frame time (utime " + std::to_string(plan_utime) + ")";
  } else if (age < -cfg.plan_max_lead_s) {
    // Its camera frame cannot come from the future: the hosts' clocks disagree, and a plan age
    // measured across them would let a stale plan run on for as long as they differ.
    std::snprintf(buf, sizeof buf,
                  "plan's camera frame is %.3f s ahead of this host's clock (limit %.3f s): the clock of the host "
                  "that stamped it runs ahead; synchronise the hosts' clocks (chrony, PTP)",
                  -age, cfg.plan_max_lead_s);
    v.stop = StopReason::ClockAhead;
    v.reason = buf;
  } else if (age > cfg.plan_max_age_s) {
    std::snprintf(buf, sizeof buf, "plan is %.3f s old (limit %.3f s)", age, cfg.plan_max_age_s);
    v.stop = StopReason::PlanStale;
    v.reason = buf;
  } else if (cfg.require_planner_heartbeat && heartbeat_age_s > cfg.planner_heartbeat_timeout_s) {
    if (heartbeat_age_s >= 1e9)
      std::snprintf(buf, sizeof buf, "no planner heartbeat received yet");
    else
      std::snprintf(buf, sizeof buf, "last planner heartbeat %.3f s ago (limit %.3f s)", heartbeat_age_s,
                    cfg.planner_heartbeat_timeout_s);
    v.stop = StopReason::HeartbeatLost;
    v.reason = buf;
  }
  return v;
}

SafetyVerdict checkSafety(const SafetyConfig& cfg, const SafetyInputs& in) {
  SafetyVerdict v;
  if (!in.following) return v;
  const double lead = std::max(0.0, in.stop_lead_s);
  v = checkNewPlan(cfg, in.now_utime + static_cast<std::int64_t>(lead * 1e6), in.plan_utime,
                   in.heartbeat_age_s >= 1e9 ? in.heartbeat_age_s : in.heartbeat_age_s + lead);
  if (v.stop != StopReason::None) return v;
  if (!in.planner_mismatch.empty()) {
    v.stop = StopReason::PlannerMismatch;
    v.reason = in.planner_mismatch;
    return v;
  }
  if (in.was_inside && !cfg.workspace.contains(in.nozzle, cfg.workspace_margin)) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "commanded nozzle at (%.3f, %.3f, %.3f) m is outside the workspace box",
                  in.nozzle.x(), in.nozzle.y(), in.nozzle.z());
    v.stop = StopReason::Workspace;
    v.reason = buf;
  }
  return v;
}

double armModelId(const ArmConfig& arm, const Workspace& workspace) {
  Digest d;
  for (const Pose* T : {&arm.T_cell_base, &arm.T_flange_nozzle})
    for (int k = 0; k < 16; ++k) d.add(T->matrix().data()[k]);
  for (const Joints* q : {&arm.q_min, &arm.q_max, &arm.qd_max, &arm.qdd_max, &arm.q_home, &arm.ik_weights})
    for (double v : *q) d.add(v);
  d.add(static_cast<double>(arm.effector.size()));
  for (const EffectorSection& s : arm.effector) d.add(s.radius).add(s.length);
  for (int k = 0; k < 3; ++k) d.add(workspace.min[k]).add(workspace.max[k]);
  return d.value();
}

std::string PlannerWatch::heard(const std::string& who, double arm_model, bool stopping, double now_s) {
  for (auto it = last_s_.begin(); it != last_s_.end();)
    it = now_s - it->second > window_s_ ? last_s_.erase(it) : std::next(it);
  if (stopping) {
    last_s_.erase(who);
    return "the planner " + who + " is stopping";
  }
  last_s_[who] = now_s;
  if (last_s_.size() > 1) {
    std::string all;
    for (const auto& [name, t] : last_s_) all += (all.empty() ? "" : ", ") + name;
    return std::to_string(last_s_.size()) + " planners publish plans (" + all +
           "): which to follow is not clear; stop all but one (or give them their own lcm.prefix)";
  }
  if (std::isfinite(arm_model) && arm_model != arm_model_) {
    char buf[320];
    std::snprintf(buf, sizeof buf,
                  "the planner %s plans for another arm or workspace (arm_model %.0f, this driver's %.0f): the robot "
                  "sections of the hosts' cell files differ (base pose, tool, joint limits, workspace)",
                  who.c_str(), arm_model, arm_model_);
    return buf;
  }
  return "";
}

}  // namespace depowder::robot
