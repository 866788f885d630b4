// The driver core (no LCM): plans in, slave-mode cycles out, safety in between.
//
// Threads: the executable's LCM thread calls submitPlan / plannerHeartbeat / estop / status;
// one loop thread calls run() (or cycle() repeatedly). In sync slave mode the controller paces
// the loop (its reply comes at the next 8 ms cycle); otherwise the loop sleeps to absolute
// CLOCK_MONOTONIC deadlines.
//
// Modes (robot_state_t.MODE_*): IDLE connected without a plan; FOLLOWING executing a plan;
// HOLDING stopped by safety (stale plan, planner heartbeat lost, workspace) until a fresh plan;
// ESTOPPED halted and motor off until estop(false); DISCONNECTED retrying the controller;
// FAULT the controller refused something (retried like a lost connection, from where the arm is).
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "depowder/pi_mutex.hpp"
#include "depowder/robot/kinematics.hpp"
#include "depowder/robot/rc8_session.hpp"
#include "depowder/robot/safety.hpp"
#include "depowder/robot/trajectory.hpp"

namespace depowder::robot {

struct DriverConfig {
  ArmConfig arm;
  TrajectoryConfig trajectory;
  SafetyConfig safety;
  SessionConfig session;
  double reconnect_period_s = 0.5;  ///< s between attempts to reach the controller
};

enum class DriverMode : int { Idle = 0, Following = 1, Holding = 2, EStopped = 3, Disconnected = 4, Fault = 5 };

const char* toString(DriverMode m);

struct DriverStats {
  std::int64_t exchanges = 0;  ///< slvMove exchanges that succeeded
  std::int64_t plans_accepted = 0;
  std::int64_t plans_refused = 0;
  std::int64_t plans_clipped = 0;     ///< accepted with speeds clipped
  std::int64_t commands_clipped = 0;  ///< cycles where the command limiter had to clip
  std::int64_t safety_stops = 0;
  std::int64_t estops = 0;
  std::int64_t reconnects = 0;  ///< successful (re)connections after the first
  std::int64_t faults = 0;      ///< controller error replies in the slave loop
};

struct DriverStatus {
  DriverMode mode = DriverMode::Disconnected;
  std::string reason;
  /// q is where the arm is: read over the current controller connection (false before the first
  /// read and whenever the connection is down; q is then the last known, or all 0)
  bool measured = false;
  Joints q{};                             ///< rad, measured (the controller's reply)
  Joints q_command{};                     ///< rad, last command sent
  Joints qd{};                            ///< rad/s, commanded velocity
  Pose T_cell_nozzle = Pose::Identity();  ///< forward kinematics of q with the tool offset
  Tool tool = Tool::kOff;
  std::int64_t plan_id = -1;
  int waypoint_index = -1;
  std::int64_t plan_utime = 0;
  std::string last_plan_result;  ///< accepted / refused, with the reason
  /// s, how far the measured position lags the commands (peak of the last seconds of motion; 0 in
  /// the emulator unless it models a servo's delay): a controlled stop starts this much earlier too
  double follow_lag_s = 0;
  DriverStats stats;
};

struct PlanResult {
  bool accepted = false;
  PlanStatus status = PlanStatus::Empty;
  std::string reason;
};

class Driver {
 public:
  /// Wall clock in microseconds since the epoch (plan utimes are wall clock); injectable for tests.
  using WallClock = std::function<std::int64_t()>;

  explicit Driver(DriverConfig config, WallClock wall_clock = {});
  ~Driver();
  Driver(const Driver&) = delete;
  Driver& operator=(const Driver&) = delete;

  // ---- inputs (any thread) ----
  /// Validates and prepares a plan (IK, workspace, speeds, age); the loop takes it over at its
  /// next cycle. A refused plan changes nothing.
  PlanResult submitPlan(const Plan& plan);
  /// A heartbeat of the planner process arrived now. `mismatch` non-empty: why it is not the
  /// planner to follow (PlannerWatch: it plans for another arm or workspace, another planner
  /// publishes too, or it is stopping); it counts as none, plans are refused and a running one is
  /// brought to a controlled stop, saying why.
  void plannerHeartbeat(const std::string& mismatch = "");
  /// stop = true: Robot_Halt at once (on the watch connection, from the caller's thread), then
  /// motor off; latched. stop = false: reset; the arm is re-enabled where it is, without a plan.
  void estop(bool stop, const std::string& why);

  // ---- the loop (one thread) ----
  /// One cycle. Returns true if the controller paced it (a sync-mode slvMove exchange).
  bool cycle();
  /// cycle() until `stop` becomes true, pacing with absolute deadlines; then brakes a moving arm
  /// to rest along its path (as a controlled stop, at most its braking time and 0.5 s) and
  /// close().
  void run(const std::atomic<bool>& stop);
  /// Orderly shutdown of the controller session.
  void close();

  DriverStatus status() const;
  /// Called after every successful slvMove exchange with its CLOCK_MONOTONIC time (benchmarks).
  void setExchangeHook(std::function<void(std::int64_t mono_ns)> hook) { exchange_hook_ = std::move(hook); }
  /// CLOCK_MONOTONIC time of the last estop(true) call and of the loop noticing it.

 private:
  bool connectAndEnable();
  bool enableFromCurrentPosition();
  void setMode(DriverMode m, const std::string& reason);
  /// An ESTOP is latched, or pressed and not yet handled by the loop (the loop thread only).
  bool estopPending() const { return estop_latched_ || estop_events_.load() != estop_seen_; }
  bool slaveCycle();
  /// follow_lag_s_ from this cycle's command and the position its reply carried.
  void updateFollowLag(const Joints& command, const Joints& measured);
  void sleepCycle();
  /// At shutdown: a controlled stop of a moving arm, cycled until it is at rest (see run()).
  void brakeToRest();
  /// Between attempts to connect or to enable again (config's reconnect_period_s).
  std::int64_t reconnectPeriodNs() const { return static_cast<std::int64_t>(cfg_.reconnect_period_s * 1e9); }

  DriverConfig cfg_;
  WallClock wall_;
  Rc8Session session_;
  TrajectoryGenerator generator_;
  CommandLimiter limiter_;

  // Shared with the input threads.
  mutable PiMutex mutex_;  // priority inheritance: the slave loop never waits behind a preempted input thread
  std::optional<PreparedPlan> incoming_;
  Plan current_plan_;  ///< raw, for resuming after a reconnect
  bool have_plan_ = false;
  std::int64_t heartbeat_ns_ = 0;  ///< CLOCK_MONOTONIC of the last planner heartbeat, 0 never
  std::string planner_mismatch_;   ///< why the last planner heartbeat did not count ("" it did)
  std::atomic<bool> estop_latched_{false};
  std::atomic<std::int64_t> estop_events_{0};  ///< estop(true) calls; the loop handles each one
  DriverStatus status_;
  Joints q_command_shared_{};

  // Loop-thread state.
  bool connected_once_ = false;
  bool estop_handled_ = false;
  std::int64_t estop_seen_ = 0;
  bool safety_stopped_ = false;
  bool was_inside_ = true;
  double follow_lag_s_ = 0;
  std::int64_t next_connect_ns_ = 0;
  std::int64_t deadline_ns_ = 0;
  std::function<void(std::int64_t)> exchange_hook_;
};

}  // namespace depowder::robot
