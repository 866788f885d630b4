// The b-CAP session with an RC8 (REFERENCE.md): ServiceStart, Controller_Connect,
// Controller_GetRobot, tool I/O variables, TakeArm, Motor on, slave mode, slvMove every cycle,
// Robot_Halt, and the orderly shutdown. Two connections, as DENSO's own driver does: "act"
// carries the slave loop; "watch" carries Robot_Halt so an emergency stop never waits behind
// a slvMove exchange.
#pragma once

#include <atomic>
#include <cstdint>
#include <mutex>
#include <string>

#include "depowder/pi_mutex.hpp"
#include "depowder/robot/bcap/client.hpp"
#include "depowder/robot/kinematics.hpp"
#include "depowder/robot/trajectory.hpp"

namespace depowder::robot {

struct SessionConfig {
  bcap::ClientConfig client;                   ///< controller address, port, timeouts (set-up calls)
  std::string service_option = "WDT=400";      ///< ServiceStart option: "still executing" every 400 ms
                                               ///< while a call runs (DENSO's clients' choice)
  std::string controller_name = "";            ///< Controller_Connect name
  std::string provider = "CaoProv.DENSO.VRC";  ///< Controller_Connect provider
  std::string machine = "localhost";           ///< Controller_Connect machine (as seen by the controller)
  std::string options = "";                    ///< Controller_Connect options
  std::string robot_name = "Arm";              ///< Controller_GetRobot name
  int slave_mode = 0x202;                      ///< slvChangeMode: sync-wait (0x200) | joint targets (2)
  double slave_reply_timeout_s = 0.1;          ///< s, reply timeout of slvMove
  std::string vacuum_variable = "IO24";        ///< controller I/O variable of the vacuum valve
  std::string air_variable = "IO25";           ///< controller I/O variable of the air valve
};

struct SessionResult {
  bool ok = true;
  bcap::CallStatus status = bcap::CallStatus::Ok;
  std::uint32_t hresult = 0;
  std::string error;  ///< which step failed and why
  static SessionResult from(const bcap::CallResult& r);
  /// The connection is gone (reconnect), as opposed to the controller refusing something.
  bool connectionLost() const;
};

class Rc8Session {
 public:
  explicit Rc8Session(SessionConfig config);
  ~Rc8Session();

  /// Connects both channels and gets the controller, robot and I/O handles.
  SessionResult open();
  /// Current joint positions (CurJnt), rad.
  SessionResult readJoints(Joints* q);
  /// ClearError (a pending controller error, e.g. after a late slave command), after leaving slave
  /// mode and giving the arm back if it was taken.
  SessionResult clearError();
  /// Slave formats (send joints only, receive joints only); TakeArm; Motor on; slave mode.
  SessionResult enable();
  /// One slave cycle: sends the target (rad), returns the controller's position (rad).
  SessionResult move(const Joints& target, Joints* measured);
  /// Switches the tool outputs (only what changed, unless `force`). A write the controller refuses
  /// ends slave mode as a refused slvMove does (the cycle's command was not sent).
  SessionResult setTool(Tool tool, bool force = false);
  /// Robot_Halt on the watch connection (safe to call from another thread).
  SessionResult halt();
  /// Leaves slave mode (if in it) and switches the motor off (after a halt).
  SessionResult motorOff();
  /// Orderly shutdown: tool off, slave mode off, GiveArm, Motor off, release handles,
  /// Controller_Disconnect, ServiceStop, close. Errors are collected, every step is tried.
  SessionResult close();
  /// Drops both connections without talking (after the controller went away).
  void abort();

  bool isOpen() const { return open_; }
  bool inSlaveMode() const { return slave_; }

 private:
  SessionResult connectChannel(bcap::Client& c, std::uint32_t* controller, std::uint32_t* robot);

  SessionConfig cfg_;
  bcap::Client act_;
  bcap::Client watch_;
  PiMutex watch_mutex_;
  std::uint32_t controller_ = 0, robot_ = 0, vacuum_ = 0, air_ = 0;
  std::uint32_t watch_controller_ = 0, watch_robot_ = 0;
  std::atomic<bool> open_{false};  ///< read by estop() on the LCM thread
  bool slave_ = false;
  bool motor_ = false;
  bool arm_taken_ = false;
  int tool_ = -1;  ///< last tool written, -1 unknown
};

}  // namespace depowder::robot
