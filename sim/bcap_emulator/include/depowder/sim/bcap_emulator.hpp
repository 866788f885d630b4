// A b-CAP controller emulator: the subset of a DENSO RC8 that depowder-driver uses, served
// over TCP (REFERENCE.md, "DENSO b-CAP"). The simulator owns one and reads the arm and the
// tool from it every step; the driver cannot tell it from a real controller.
//
// Implemented: ServiceStart/Stop, Controller_Connect/Disconnect/GetRobot/GetVariable/Execute
// ("ClearError"), Robot_Execute ("Motor", "TakeArm", "GiveArm", "slvChangeMode", "slvMove",
// "CurJnt", "ExtSpeed", "slvSendFormat"/"slvRecvFormat" defaults only), Robot_Halt,
// Robot_Release, Variable_GetValue/PutValue/Release. Handles are global; the arm belongs to
// the connection that took it and is released (stopped) when that connection closes.
// Slave mode: joint targets (mode 0x?02) in degrees, 6..8 elements (or 8 and an option word 0, as
// DENSO's own driver sends), one per 8 ms cycle; in
// sync mode (0x200) the reply waits for the next cycle and a command later than 16 ms after
// the previous one is an error that stops the arm. Errors that stop the arm switch the motor
// off and stay pending until Controller_Execute("ClearError").
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "depowder/pi_mutex.hpp"
#include "depowder/robot/bcap/packet.hpp"
#include "depowder/robot/kinematics.hpp"

namespace depowder::sim {

struct BcapEmulatorConfig {
  std::string bind_address = "127.0.0.1";               ///< loopback unless configured (IPv4)
  int port = 5007;                                      ///< 0: any free port (tests; see BcapEmulator::port())
  robot::Joints q_min = robot::ArmConfig().q_min;       ///< rad, targets outside are refused
  robot::Joints q_max = robot::ArmConfig().q_max;       ///< rad
  robot::Joints qd_max = robot::ArmConfig().qd_max;     ///< rad/s, per-cycle step limit (with speed_margin)
  robot::Joints q_initial = robot::ArmConfig().q_home;  ///< rad, the arm at start
  double cycle_s = 0.008;                               ///< s, slave-mode control cycle (RC8: 8 ms)
  double late_limit_s = 0.016;    ///< s, sync mode: a slvMove this long after the previous is an error
  double speed_margin = 1.5;      ///< a cycle may move a joint by qd_max * cycle_s * speed_margin
  int servo_lag_cycles = 0;       ///< the arm reaches a slvMove's target this many cycles later (a servo's following
                                  ///< delay; 0: at once); the reply carries where the arm is
  double motor_on_time_s = 0.05;  ///< s, "Motor 1" takes this long (the servo powering up); on a
                                  ///< connection whose ServiceStart asked for "WDT=ms", a "still
                                  ///< executing" reply goes out every WDT meanwhile, as DENSO's server does
  std::string vacuum_variable = "IO24";  ///< controller I/O variable that switches the vacuum
  std::string air_variable = "IO25";     ///< controller I/O variable that switches the air blast
  int max_connections = 8;               ///< further connections are closed at once
  bool realtime = true;  ///< try SCHED_FIFO for the connection threads (a real RC8 is real-time); ignored
                         ///< without the privilege
};

struct EmulatorJointState {
  robot::Joints q{};   ///< rad, current joint positions
  robot::Joints qd{};  ///< rad/s, over the last cycle (0 when no command came for 2 cycles)
  bool motor_on = false;
  bool slave_mode = false;
  std::int64_t slave_moves = 0;  ///< accepted slvMove commands
};

struct EmulatorToolState {
  bool vacuum = false;
  bool air = false;
};

struct EmulatorStats {
  std::int64_t connections = 0;       ///< accepted
  std::int64_t packets = 0;           ///< requests decoded
  std::int64_t malformed = 0;         ///< requests that did not decode (error reply or closed)
  std::int64_t error_replies = 0;     ///< failure HRESULTs sent
  std::int64_t late_errors = 0;       ///< slvMove later than late_limit_s
  std::int64_t limit_errors = 0;      ///< targets outside the joint limits
  std::int64_t speed_errors = 0;      ///< targets too far for one cycle
  std::int64_t halts = 0;             ///< Robot_Halt calls
  std::int64_t abrupt_exits = 0;      ///< slave mode left with the arm moving (stopped at once, not braked)
  std::int64_t motor_on_untaken = 0;  ///< Motor 1 from a client without the arm (DENSO's samples take it first)
  int send_format = -1;               ///< the last slvSendFormat set (-1: never; the controller keeps it)
  int recv_format = -1;               ///< the last slvRecvFormat set (-1: never)
  std::string last_error;             ///< description of the last error reply
  std::string last_refusal;           ///< ...and of the last late / limit / speed error (the arm's refusals)
};

class BcapEmulator {
 public:
  explicit BcapEmulator(BcapEmulatorConfig config = {});
  ~BcapEmulator();
  BcapEmulator(const BcapEmulator&) = delete;
  BcapEmulator& operator=(const BcapEmulator&) = delete;

  /// Binds, listens and starts serving. False with `error` set if the address cannot be bound.
  bool start(std::string* error = nullptr);
  /// Closes every connection and joins the threads (also done by the destructor).
  void stop();
  /// The bound port (useful with port 0).
  int port() const { return bound_port_; }

  // Thread-safe accessors for the simulator's main loop (call once a step).
  EmulatorJointState joints() const;
  EmulatorToolState tool() const;
  /// True once the arm was stopped by Robot_Halt or an error, until slave mode is entered again.
  bool halted() const;
  /// Steady-clock time of the last halt (Robot_Halt or an error that stopped the arm).
  std::optional<std::chrono::steady_clock::time_point> lastHaltTime() const;
  EmulatorStats stats() const;

  /// Puts the arm somewhere (a simulator reset). Refused (false) while in slave mode.
  bool setJoints(const robot::Joints& q);
  /// A controller error (e.g. a collision detected by the simulator): the arm stops, the
  /// motor goes off, the error stays pending until ClearError.
  void raiseError(const std::string& why);
  /// Closes every client connection (a cable pulled); the server keeps listening.
  void dropConnections();
  /// Tests: each sync-mode slvMove reply leaves this long after its cycle, as when this
  /// emulator's own host stalls it. Not the client's time: no late-command error for it.
  void stallRepliesForTest(double seconds) { reply_stall_ns_ = static_cast<std::int64_t>(seconds * 1e9); }
  /// Tests: the next `n` Variable_PutValue requests are refused (E_ACCESSDENIED), as a controller
  /// refuses a write to an I/O it does not allow.
  void refuseIoWritesForTest(int n) { io_refusals_ = n; }

  /// Handles one request as the server does (exposed for tests). `connection` identifies the
  /// caller for arm ownership. May block until the next cycle for a sync-mode slvMove, or for
  /// motor_on_time_s for "Motor 1", during which `partial` gets the "still executing" replies
  /// (every WDT of the connection's ServiceStart option; none without one).
  using PartialReply = std::function<void(const robot::bcap::Packet&)>;
  robot::bcap::Packet handle(const robot::bcap::Packet& request, int connection, const PartialReply& partial = {});
  /// Called when a connection ends: releases its arm (stopping slave mode) and its handles.
  void connectionClosed(int connection);

 private:
  struct Handle {
    enum Kind { Controller, Robot, Variable } kind;
    int connection;
    std::string name;
  };
  struct Connection;

  void acceptLoop();
  void serve(std::shared_ptr<Connection> conn);
  robot::bcap::Packet reply(const robot::bcap::Packet& req, std::uint32_t hresult,
                            std::vector<robot::bcap::Variant> values = {});
  robot::bcap::Packet error(const robot::bcap::Packet& req, std::uint32_t hresult, const std::string& why);
  robot::bcap::Packet robotExecute(const robot::bcap::Packet& req, int connection, const PartialReply& partial);
  robot::bcap::Packet slvMove(const robot::bcap::Packet& req, int connection, const robot::bcap::Variant& param);
  /// The arm at rest where it is, no slave cycle running (caller holds mutex_): zero velocity, no
  /// target on the way, the cycle clock restarted by the next slvMove.
  void restLocked();
  /// Stops the arm (caller holds mutex_): leaves slave mode, at rest (restLocked), halted.
  void stopArmLocked(bool motor_off);
  std::optional<std::uint32_t> handleArg(const robot::bcap::Packet& req, std::size_t i, Handle::Kind kind) const;
  std::vector<double> jointsDegreesLocked() const;

  BcapEmulatorConfig config_;
  int listen_fd_ = -1;
  int bound_port_ = 0;
  std::atomic<bool> running_{false};
  std::thread accept_thread_;
  std::mutex connections_mutex_;
  std::vector<std::shared_ptr<Connection>> connections_;
  int next_connection_ = 1;

  mutable PiMutex mutex_;  // priority inheritance: the connection threads never wait behind the simulator's step
  std::map<std::uint32_t, Handle> handles_;
  std::map<int, double> wdt_s_;  ///< per connection, ServiceStart's "WDT=ms" (s); absent: none
  std::uint32_t next_handle_ = 1;
  robot::Joints q_{};  ///< where the arm is
  robot::Joints qd_{};
  std::deque<robot::Joints> on_the_way_;  ///< targets the arm has not reached yet (servo_lag_cycles)
  struct AsyncTarget {
    std::int64_t at_ns;            ///< CLOCK_MONOTONIC of its arrival
    robot::Joints target, before;  ///< the command, and the target in effect when it came
  };
  std::deque<AsyncTarget> async_targets_;  ///< async slave mode: the commands of the last cycle and the one before
  bool motor_on_ = false;
  int arm_owner_ = 0;  ///< connection id, 0 = free
  int slave_mode_ = 0;
  bool halted_ = false;
  bool error_pending_ = false;
  std::optional<std::chrono::steady_clock::time_point> halt_time_;
  std::int64_t last_move_ns_ = 0;                ///< CLOCK_MONOTONIC of the last applied slvMove (its cycle)
  std::int64_t last_reply_ns_ = 0;               ///< CLOCK_MONOTONIC when that slvMove's reply went out
  std::atomic<std::int64_t> reply_stall_ns_{0};  ///< stallRepliesForTest
  std::atomic<int> io_refusals_{0};              ///< refuseIoWritesForTest
  std::int64_t cycle_origin_ns_ = 0;
  std::int64_t slave_moves_ = 0;
  std::map<std::string, bool> io_;
  EmulatorStats stats_;
};

}  // namespace depowder::sim
