#include "depowder/robot/driver.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

namespace depowder::robot {
namespace {

std::int64_t monoNs() { return bcap::monotonicNs(); }

std::int64_t systemUtime() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace

const char* toString(DriverMode m) {
  switch (m) {
    case DriverMode::Idle:
      return "idle";
    case DriverMode::Following:
      return "following";
    case DriverMode::Holding:
      return "holding";
    case DriverMode::EStopped:
      return "estopped";
    case DriverMode::Disconnected:
      return "disconnected";
    case DriverMode::Fault:
      return "fault";
  }
  return "?";
}

Driver::Driver(DriverConfig config, WallClock wall_clock)
    : cfg_(std::move(config)),
      wall_(wall_clock ? std::move(wall_clock) : WallClock(systemUtime)),
      session_(cfg_.session),
      generator_(cfg_.arm, cfg_.trajectory),
      limiter_(cfg_.arm, cfg_.trajectory.cycle_s, cfg_.safety.limit_tolerance) {
  status_.mode = DriverMode::Disconnected;
  status_.reason = "not connected yet";
  q_command_shared_ = cfg_.arm.q_home;
}

Driver::~Driver() { session_.abort(); }

// ---- inputs ---------------------------------------------------------------------------------------

PlanResult Driver::submitPlan(const Plan& plan) {
  PlanResult res;
  Joints q_start;
  double hb_age;
  std::string mismatch;
  {
    std::lock_guard<PiMutex> lock(mutex_);
    q_start = q_command_shared_;
    hb_age = heartbeat_ns_ == 0 ? 1e9 : static_cast<double>(monoNs() - heartbeat_ns_) * 1e-9;
    mismatch = planner_mismatch_;
  }
  auto refuse = [&](PlanStatus s, const std::string& why) {
    res.accepted = false;
    res.status = s;
    res.reason = why;
    std::lock_guard<PiMutex> lock(mutex_);
    ++status_.stats.plans_refused;
    status_.last_plan_result = "plan " + std::to_string(plan.id) + " refused: " + why;
    return res;
  };
  if (estop_latched_) return refuse(PlanStatus::Empty, "ESTOP is active (reset it first)");
  // A plan with waypoints must be fresh and its planner alive. An empty one is a controlled stop
  // (the planner's hold, sent before it has a frame to plan from): taken whatever its age.
  if (!plan.waypoints.empty()) {
    if (!mismatch.empty()) return refuse(PlanStatus::Empty, mismatch);
    const SafetyVerdict fresh = checkNewPlan(cfg_.safety, wall_(), plan.utime, hb_age);
    if (fresh.stop == StopReason::PlanStale && plan.utime > 0)
      return refuse(PlanStatus::Empty,
                    fresh.reason +
                        " on arrival: the cell's frames are that late, or the clock of the host that "
                        "stamped it runs behind this host's");
    if (fresh.stop != StopReason::None) return refuse(PlanStatus::Empty, fresh.reason);
  }

  PreparedPlan pp = preparePlan(cfg_.arm, cfg_.trajectory, cfg_.safety.workspace, plan, q_start);
  if (!pp.usable() && pp.status != PlanStatus::Empty)
    return refuse(pp.status, std::string(toString(pp.status)) + ": " + pp.reason);
  std::unique_lock<PiMutex> lock(mutex_);
  // An ESTOP that came while the plan was prepared (it is handled on another thread) wins.
  if (estop_latched_) {
    lock.unlock();
    return refuse(PlanStatus::Empty, "ESTOP is active (reset it first)");
  }
  res.accepted = true;
  res.status = pp.status;
  res.reason = pp.reason;
  ++status_.stats.plans_accepted;
  if (pp.status == PlanStatus::Clipped) ++status_.stats.plans_clipped;
  status_.last_plan_result =
      "plan " + std::to_string(plan.id) + " " + toString(pp.status) + (pp.reason.empty() ? "" : ": " + pp.reason);
  incoming_ = std::move(pp);
  current_plan_ = plan;
  have_plan_ = !plan.waypoints.empty();
  return res;
}

void Driver::plannerHeartbeat(const std::string& mismatch) {
  std::lock_guard<PiMutex> lock(mutex_);
  planner_mismatch_ = mismatch;
  if (mismatch.empty()) heartbeat_ns_ = monoNs();
}

void Driver::estop(bool stop, const std::string& why) {
  if (stop) {
    const bool first = !estop_latched_.exchange(true);
    if (first) ++estop_events_;
    // Halt at once from this thread: the watch connection never waits behind a slvMove.
    const SessionResult halted = session_.isOpen() ? session_.halt() : SessionResult{};
    std::lock_guard<PiMutex> lock(mutex_);
    if (first) ++status_.stats.estops;
    status_.mode = DriverMode::EStopped;
    status_.reason = "ESTOP: " + why;
    if (!halted.ok) status_.reason += " (Robot_Halt failed: " + halted.error + "; the loop switches the motor off)";
    incoming_.reset();
    have_plan_ = false;
  } else {
    estop_latched_ = false;
  }
}

DriverStatus Driver::status() const {
  std::lock_guard<PiMutex> lock(mutex_);
  return status_;
}

void Driver::setMode(DriverMode m, const std::string& reason) {
  // estop() has reported ESTOPPED: an enable or a plan taken meanwhile does not report otherwise.
  if ((m == DriverMode::Idle || m == DriverMode::Following) && estopPending()) return;
  std::lock_guard<PiMutex> lock(mutex_);
  status_.mode = m;
  status_.reason = reason;
  // Without a connection the arm may move (jogged, or braking after a controller error): its last
  // position read is no longer where it is.
  if (!session_.isOpen()) status_.measured = false;
}

// ---- the loop -------------------------------------------------------------------------------------

bool Driver::enableFromCurrentPosition() {
  // Whatever happened before, start from where the arm really is: no jump.
  session_.clearError();
  Joints q;
  SessionResult r = session_.readJoints(&q);
  if (!r.ok) {
    if (r.connectionLost()) session_.abort();
    setMode(r.connectionLost() ? DriverMode::Disconnected : DriverMode::Fault, r.error);
    return false;
  }
  generator_.reset(q);
  limiter_.reset(q);
  // An arm found outside the box (moved by hand) may be led back in; only leaving it stops.
  was_inside_ = cfg_.safety.workspace.contains(forwardNozzle(cfg_.arm, q).translation(), cfg_.safety.workspace_margin);
  safety_stopped_ = false;
  {
    std::lock_guard<PiMutex> lock(mutex_);
    q_command_shared_ = q;
    status_.measured = true;
    status_.q = q;
    status_.q_command = q;
    status_.qd = {};
    status_.T_cell_nozzle = forwardNozzle(cfg_.arm, q);
  }
  if (estop_latched_) {
    session_.motorOff();
    estop_handled_ = true;
    estop_seen_ = estop_events_.load();
    setMode(DriverMode::EStopped, "ESTOP active; waiting for a reset");
    return true;
  }
  // An arm outside the configured limits (jogged there, or limits narrowed in the cell file)
  // is not enabled: the command limiter would pull it in on its own.
  for (int i = 0; i < 6; ++i)
    if (!(q[i] >= cfg_.arm.q_min[i] && q[i] <= cfg_.arm.q_max[i])) {
      char why[200];
      std::snprintf(why, sizeof why,
                    "J%d at %.2f deg is outside the configured limits [%.2f, %.2f] deg; move it inside (teach "
                    "pendant) or widen robot.q_min / q_max",
                    i + 1, q[i] * 180 / M_PI, cfg_.arm.q_min[i] * 180 / M_PI, cfg_.arm.q_max[i] * 180 / M_PI);
      setMode(DriverMode::Fault, why);
      return false;
    }
  r = session_.enable();
  if (!r.ok) {
    if (r.connectionLost()) session_.abort();
    setMode(r.connectionLost() ? DriverMode::Disconnected : DriverMode::Fault, r.error);
    return false;
  }
  session_.setTool(Tool::kOff, true);
  estop_handled_ = false;
  // Resume the current plan (if still fresh) from its next waypoint, from where the arm is. A
  // plan taken while the controller was away was prepared from the last command, not from where
  // the arm is now (it may have been moved meanwhile): it is prepared again, from its start.
  Plan resume;
  bool have = false;
  int from = 0;
  {
    std::lock_guard<PiMutex> lock(mutex_);
    if (have_plan_) {
      resume = current_plan_;
      have = true;
      // The status names the plan the arm ran last: a newer one (taken, or still braking into
      // it) starts from its beginning.
      from = incoming_ || status_.plan_id != resume.id ? 0 : std::max(0, status_.waypoint_index);
      incoming_.reset();
    }
  }
  if (have) {
    const PreparedPlan pp = preparePlan(cfg_.arm, cfg_.trajectory, cfg_.safety.workspace, resume, q, from);
    if (pp.usable()) {
      generator_.setPlan(pp);
      setMode(DriverMode::Following, "resuming plan " + std::to_string(resume.id) + " from waypoint " +
                                         std::to_string(from) + " where the arm is");
      return true;
    }
  }
  setMode(DriverMode::Idle, "connected");
  return true;
}

bool Driver::connectAndEnable() {
  const std::int64_t now = monoNs();
  if (now < next_connect_ns_) return false;
  next_connect_ns_ = now + reconnectPeriodNs();
  const SessionResult r = session_.open();
  if (!r.ok) {
    // Unreachable, or reached and refusing (a wrong robot or I/O name in the cell file).
    if (r.connectionLost())
      setMode(DriverMode::Disconnected, "controller unreachable: " + r.error);
    else
      setMode(DriverMode::Fault, "controller refused the session: " + r.error);
    return false;
  }
  if (connected_once_) {
    std::lock_guard<PiMutex> lock(mutex_);
    ++status_.stats.reconnects;
  }
  connected_once_ = true;
  return enableFromCurrentPosition();
}

void Driver::sleepCycle() {
  const std::int64_t cycle = static_cast<std::int64_t>(cfg_.trajectory.cycle_s * 1e9);
  const std::int64_t now = monoNs();
  if (deadline_ns_ == 0 || deadline_ns_ < now - cycle) deadline_ns_ = now;
  deadline_ns_ += cycle;
  bcap::sleepUntilNs(deadline_ns_);
}

bool Driver::cycle() {
  // 1. Controller connection.
  if (!session_.isOpen()) {
    connectAndEnable();
    return false;
  }
  // 2. ESTOP: halted already by estop(); switch the motor off once per event (even if the
  //    reset came before this loop noticed), then wait for the reset.
  const std::int64_t events = estop_events_.load();
  if (events != estop_seen_) {
    estop_seen_ = events;
    session_.halt();
    session_.setTool(Tool::kOff, true);
    session_.motorOff();
    generator_.reset(limiter_.last());
    estop_handled_ = true;
    std::lock_guard<PiMutex> lock(mutex_);
    status_.mode = DriverMode::EStopped;
    status_.qd = {};
    status_.tool = Tool::kOff;
  }
  if (estop_latched_) return false;
  if (estop_handled_) {
    // Reset: re-enable where the arm is, without a plan; after a failed attempt (the arm outside
    // its limits, the controller refusing), the next one reconnect_period later.
    const std::int64_t now = monoNs();
    if (now < next_connect_ns_) return false;
    {
      std::lock_guard<PiMutex> lock(mutex_);
      have_plan_ = false;
      incoming_.reset();
      status_.plan_id = -1;
      status_.waypoint_index = -1;
    }
    if (!enableFromCurrentPosition()) {
      next_connect_ns_ = now + reconnectPeriodNs();
      return false;
    }
    // A new ESTOP while re-enabling leaves it EStopped (enableFromCurrentPosition said so).
    if (estop_latched_) return false;
    setMode(DriverMode::Idle, "ESTOP reset");
    return false;
  }
  // 3. Fault recovery (controller refused something): clear, re-read, re-enable.
  if (!session_.inSlaveMode()) {
    const std::int64_t now = monoNs();
    if (now < next_connect_ns_) return false;
    next_connect_ns_ = now + reconnectPeriodNs();
    enableFromCurrentPosition();
    return false;
  }
  return slaveCycle();
}

bool Driver::slaveCycle() {
  // 4. Take over a new plan.
  std::optional<PreparedPlan> incoming;
  double hb_age;
  std::int64_t plan_utime;
  std::string mismatch;
  bool have_plan;
  {
    std::lock_guard<PiMutex> lock(mutex_);
    incoming.swap(incoming_);
    hb_age = heartbeat_ns_ == 0 ? 1e9 : static_cast<double>(monoNs() - heartbeat_ns_) * 1e-9;
    mismatch = planner_mismatch_;
    plan_utime = current_plan_.utime;
    have_plan = have_plan_;
  }
  if (incoming) {
    generator_.setPlan(*incoming);
    safety_stopped_ = false;
  }

  // 5. Safety: stale plan, planner heartbeat, workspace -> controlled stop.
  // A finished plan has nothing left to stop, but its last tool state must not outlive it.
  if (have_plan && generator_.finished() && generator_.current().tool != Tool::kOff &&
      checkNewPlan(cfg_.safety, wall_(), plan_utime, hb_age).stop != StopReason::None) {
    generator_.stop();
  }
  SafetyInputs in;
  in.following = have_plan && !safety_stopped_ && !generator_.finished();
  in.now_utime = wall_();
  in.plan_utime = plan_utime;
  in.heartbeat_age_s = hb_age;
  in.nozzle = forwardNozzle(cfg_.arm, limiter_.last()).translation();
  in.was_inside = was_inside_;
  in.planner_mismatch = mismatch;
  // Braking (in whole cycles, with a 20 % margin) plus the cycle that notices, the cycle that
  // sends the first unchanged command and the time the arm takes to reach the last one.
  in.stop_lead_s = 1.2 * generator_.brakingTime() + 2 * cfg_.trajectory.cycle_s + follow_lag_s_;
  const SafetyVerdict verdict = checkSafety(cfg_.safety, in);
  if (verdict.stop != StopReason::None) {
    generator_.stop();
    safety_stopped_ = true;
    std::lock_guard<PiMutex> lock(mutex_);
    have_plan_ = false;
    ++status_.stats.safety_stops;
    // Reported as HOLDING once the arm is at rest (step 8); FOLLOWING while it brakes.
    status_.reason = std::string("controlled stop: ") + verdict.reason;
  }

  // 6. Next command, limited. Step 5 of the next cycle checks it against where the last one was.
  was_inside_ = cfg_.safety.workspace.contains(in.nozzle, cfg_.safety.workspace_margin);
  const TrajectorySample sample = generator_.step();
  const CommandLimiter::Result cmd = limiter_.apply(sample.q);

  // 7. Tool, then the slave exchange.
  SessionResult r = session_.setTool(sample.tool);
  Joints measured{};
  if (r.ok) r = session_.move(cmd.q, &measured);
  const std::int64_t t_done = monoNs();
  if (!r.ok) {
    // An ESTOP halted the arm under this exchange: not a fault, the next cycle handles it.
    if (estop_events_.load() != estop_seen_) return false;
    const bool lost = r.connectionLost();
    if (lost) session_.abort();
    std::lock_guard<PiMutex> lock(mutex_);
    if (!lost) ++status_.stats.faults;
    status_.mode = lost ? DriverMode::Disconnected : DriverMode::Fault;
    if (lost) status_.measured = false;
    status_.reason = (lost ? "controller connection lost: " : "controller error: ") + r.error;
    status_.qd = {};
    return false;
  }
  if (exchange_hook_) exchange_hook_(t_done);
  updateFollowLag(cmd.q, measured);

  // 8. Status.
  std::lock_guard<PiMutex> lock(mutex_);
  ++status_.stats.exchanges;
  if (cmd.clipped()) ++status_.stats.commands_clipped;
  q_command_shared_ = cmd.q;
  status_.q = measured;
  status_.q_command = cmd.q;
  status_.qd = limiter_.velocity();
  status_.T_cell_nozzle = forwardNozzle(cfg_.arm, measured);
  status_.tool = sample.tool;
  status_.plan_id = sample.plan_id;
  status_.waypoint_index = sample.waypoint_index;
  status_.plan_utime = plan_utime;
  status_.follow_lag_s = follow_lag_s_;
  if (estopPending()) {
    // An ESTOP came during this exchange: estop() has reported it; the next cycle switches the
    // motor off. Reporting FOLLOWING meanwhile would say the arm moves on.
  } else if (safety_stopped_) {
    status_.mode = sample.moving ? DriverMode::Following : DriverMode::Holding;
  } else if (sample.moving || (have_plan_ && !generator_.finished())) {
    status_.mode = DriverMode::Following;
    status_.reason = "following plan " + std::to_string(sample.plan_id);
  } else {
    status_.mode = DriverMode::Idle;
    status_.reason = generator_.finished() ? "plan " + std::to_string(sample.plan_id) + " done" : "no plan";
  }
  return (cfg_.session.slave_mode & 0x200) != 0;
}

void Driver::updateFollowLag(const Joints& command, const Joints& measured) {
  // The joint commanded fastest: its offset from the reply, over its speed, is how long the arm
  // takes to reach a command. A peak, forgotten over about 10 s; not measured while braking (the
  // offset then spans faster steps) nor below 0.05 rad/s (the offset is then mostly noise).
  const Joints& v = limiter_.velocity();
  int fastest = 0;
  for (int i = 1; i < 6; ++i)
    if (std::abs(v[i]) > std::abs(v[fastest])) fastest = i;
  follow_lag_s_ *= 1.0 - cfg_.trajectory.cycle_s / 10.0;
  if (generator_.stopping() || std::abs(v[fastest]) < 0.05) return;
  const double lag = std::abs(command[fastest] - measured[fastest]) / std::abs(v[fastest]);
  follow_lag_s_ = std::max(follow_lag_s_, std::min(lag, 0.5));
}

void Driver::run(const std::atomic<bool>& stop) {
  while (!stop) {
    const bool paced = cycle();
    if (paced) {
      deadline_ns_ = monoNs();  // the controller's cycle is the clock
    } else {
      sleepCycle();
    }
  }
  brakeToRest();
  close();
}

void Driver::brakeToRest() {
  // Leaving slave mode at speed would stop the arm at once (on a real controller, an error
  // stop): an orderly shutdown first brakes along the path, as a controlled stop does, and holds
  // the last command until the arm has reached it.
  if (!session_.isOpen() || !session_.inSlaveMode() || estop_latched_) return;
  generator_.stop();
  {
    std::lock_guard<PiMutex> lock(mutex_);
    have_plan_ = false;
    incoming_.reset();
    status_.reason = "driver stopping: braking to rest";
  }
  const double cycle_s = cfg_.trajectory.cycle_s;
  const std::int64_t now = monoNs();
  const std::int64_t give_up =
      now + static_cast<std::int64_t>((1.2 * generator_.brakingTime() + follow_lag_s_ + 0.5) * 1e9);
  std::int64_t at_rest = -1;  // when the arm will have reached the last command
  while (!estop_latched_ && session_.inSlaveMode() && monoNs() < give_up) {
    if (!generator_.current().moving) {
      if (at_rest < 0) at_rest = monoNs() + static_cast<std::int64_t>((follow_lag_s_ + 2 * cycle_s) * 1e9);
      if (monoNs() >= at_rest) break;
    }
    if (cycle())
      deadline_ns_ = monoNs();
    else
      sleepCycle();
  }
}

void Driver::close() {
  if (session_.isOpen()) session_.close();
  setMode(DriverMode::Disconnected, "driver stopped");
}

}  // namespace depowder::robot
