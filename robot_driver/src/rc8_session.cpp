#include "depowder/robot/rc8_session.hpp"

#include <cmath>

namespace depowder::robot {

using bcap::CallResult;
using bcap::CallStatus;
using bcap::Variant;

namespace {
constexpr double kDeg = 180.0 / 3.14159265358979323846;

// Joint angles (rad) from a controller position array (deg, 6..8 elements).
bool jointsFrom(const CallResult& r, Joints* q, std::string* why) {
  if (r.values.empty()) {
    *why = "reply without a position";
    return false;
  }
  const auto v = r.values[0].asReals();
  if (!v || v->size() < 6) {
    *why = "reply position is not an array of at least 6 numbers";
    return false;
  }
  for (int i = 0; i < 6; ++i) {
    if (!std::isfinite((*v)[i])) {
      *why = "reply position is not finite";
      return false;
    }
    (*q)[i] = (*v)[i] / kDeg;
  }
  return true;
}
}  // namespace

SessionResult SessionResult::from(const CallResult& r) {
  SessionResult s;
  s.ok = r.ok();
  s.status = r.status;
  s.hresult = r.hresult;
  s.error = r.error;
  return s;
}

bool SessionResult::connectionLost() const {
  return !ok &&
         (status == CallStatus::Disconnected || status == CallStatus::Timeout || status == CallStatus::NotConnected ||
          status == CallStatus::ConnectFailed || status == CallStatus::ProtocolError);
}

Rc8Session::Rc8Session(SessionConfig config) : cfg_(std::move(config)), act_(cfg_.client), watch_(cfg_.client) {}

Rc8Session::~Rc8Session() { abort(); }

SessionResult Rc8Session::connectChannel(bcap::Client& c, std::uint32_t* controller, std::uint32_t* robot) {
  CallResult r = c.connect();
  if (!r.ok()) return SessionResult::from(r);
  r = c.serviceStart(cfg_.service_option);
  if (!r.ok()) return SessionResult::from(r);
  r = c.controllerConnect(cfg_.controller_name, cfg_.provider, cfg_.machine, cfg_.options);
  if (!r.ok()) return SessionResult::from(r);
  if (!r.handle()) {
    SessionResult s;
    s.ok = false;
    s.status = CallStatus::ProtocolError;
    s.error = "Controller_Connect: reply without a handle";
    return s;
  }
  *controller = *r.handle();
  r = c.controllerGetRobot(*controller, cfg_.robot_name);
  if (!r.ok()) return SessionResult::from(r);
  if (!r.handle()) {
    SessionResult s;
    s.ok = false;
    s.status = CallStatus::ProtocolError;
    s.error = "Controller_GetRobot: reply without a handle";
    return s;
  }
  *robot = *r.handle();
  return {};
}

SessionResult Rc8Session::open() {
  abort();
  SessionResult s = connectChannel(act_, &controller_, &robot_);
  if (!s.ok) return s;
  {
    std::lock_guard<PiMutex> lock(watch_mutex_);
    s = connectChannel(watch_, &watch_controller_, &watch_robot_);
  }
  if (!s.ok) {
    abort();
    return s;
  }
  for (auto [name, handle] : {std::pair{&cfg_.vacuum_variable, &vacuum_}, std::pair{&cfg_.air_variable, &air_}}) {
    const CallResult r = act_.controllerGetVariable(controller_, *name);
    s = SessionResult::from(r);
    if (r.ok() && !r.handle()) {
      s.ok = false;
      s.status = CallStatus::ProtocolError;
      s.error = "reply without a handle";
    }
    if (!s.ok) {
      abort();
      s.error = "Controller_GetVariable(" + *name + "): " + s.error;
      return s;
    }
    *handle = *r.handle();
  }
  open_ = true;
  slave_ = false;
  tool_ = -1;
  return {};
}

SessionResult Rc8Session::readJoints(Joints* q) {
  const CallResult r = act_.robotExecute(robot_, "CurJnt");
  if (!r.ok()) return SessionResult::from(r);
  SessionResult s;
  if (!jointsFrom(r, q, &s.error)) {
    s.ok = false;
    s.status = CallStatus::ProtocolError;
    s.error = "CurJnt: " + s.error;
  }
  return s;
}

SessionResult Rc8Session::clearError() {
  // As DENSO's driver recovers (ChangeModeWithClearError): out of slave mode and the arm given
  // back before ClearError, which is not for slave mode. Their own errors are of no interest (an
  // error that stopped the arm has ended slave mode already); enable() takes the arm again.
  if (arm_taken_) {
    act_.setReplyTimeout(cfg_.client.reply_timeout_s);
    act_.robotExecute(robot_, "slvChangeMode", Variant::i4(0));
    act_.robotExecute(robot_, "GiveArm");
    slave_ = arm_taken_ = false;
  }
  return SessionResult::from(act_.controllerExecute(controller_, "ClearError"));
}

SessionResult Rc8Session::enable() {
  // The slvMove formats, set as DENSO's driver sets them before TakeArm (the controller keeps the
  // last ones set): the command is the joint array alone (slvSendFormat 0), the reply the joint
  // array alone (slvRecvFormat 2; another format would put a position where jointsFrom reads joints).
  CallResult r = act_.robotExecute(robot_, "slvSendFormat", Variant::i4(0));
  if (!r.ok()) return SessionResult::from(r);
  r = act_.robotExecute(robot_, "slvRecvFormat", Variant::i4(2));
  if (!r.ok()) return SessionResult::from(r);
  // The arm first, then its motor, as DENSO's b-CAP samples do.
  r = act_.robotExecute(robot_, "TakeArm", Variant::i4Array({0, 1}));
  if (!r.ok()) return SessionResult::from(r);
  arm_taken_ = true;
  r = act_.robotExecute(robot_, "Motor", Variant::i4(1));
  if (!r.ok()) return SessionResult::from(r);
  motor_ = true;
  r = act_.robotExecute(robot_, "slvChangeMode", Variant::i4(cfg_.slave_mode));
  if (!r.ok()) return SessionResult::from(r);
  slave_ = true;
  act_.setReplyTimeout(cfg_.slave_reply_timeout_s);  // the slave cycle's
  return {};
}

SessionResult Rc8Session::move(const Joints& target, Joints* measured) {
  // As DENSO's own driver sends it (denso_robot_core, CreateSendParameter): the 8 joints (deg; J7
  // and J8 unused on the VS-6577) and an option word of 0.
  std::vector<double> deg(9, 0.0);
  for (int i = 0; i < 6; ++i) deg[i] = target[i] * kDeg;
  const CallResult r = act_.robotExecute(robot_, "slvMove", Variant::r8Array(deg));
  if (!r.ok()) {
    if (r.status == CallStatus::ControllerError) slave_ = false;  // the controller stopped the arm
    return SessionResult::from(r);
  }
  SessionResult s;
  if (!jointsFrom(r, measured, &s.error)) {
    s.ok = false;
    s.status = CallStatus::ProtocolError;
    s.error = "slvMove: " + s.error;
  }
  return s;
}

SessionResult Rc8Session::setTool(Tool tool, bool force) {
  const int t = static_cast<int>(tool);
  if (!force && t == tool_) return {};
  // A refused write in slave mode ends this slave session as a refused slvMove does: the cycle's
  // command was not sent, so the driver starts again from where the arm is (clearError, enable).
  auto refused = [&](const CallResult& r, const std::string& variable) {
    if (r.status == CallStatus::ControllerError) slave_ = false;
    tool_ = -1;
    SessionResult s = SessionResult::from(r);
    s.error = "writing the tool output " + variable + ": " + s.error;
    return s;
  };
  CallResult r = act_.variablePutValue(vacuum_, Variant::boolean(tool == Tool::kVacuum));
  if (!r.ok()) return refused(r, cfg_.vacuum_variable);
  r = act_.variablePutValue(air_, Variant::boolean(tool == Tool::kAir));
  if (!r.ok()) return refused(r, cfg_.air_variable);
  tool_ = t;
  return {};
}

SessionResult Rc8Session::halt() {
  std::lock_guard<PiMutex> lock(watch_mutex_);
  const CallResult r = watch_.robotHalt(watch_robot_);
  return SessionResult::from(r);
}

SessionResult Rc8Session::motorOff() {
  act_.setReplyTimeout(cfg_.client.reply_timeout_s);
  if (slave_) act_.robotExecute(robot_, "slvChangeMode", Variant::i4(0));
  slave_ = false;
  const CallResult r = act_.robotExecute(robot_, "Motor", Variant::i4(0));
  if (r.ok()) motor_ = false;
  return SessionResult::from(r);
}

SessionResult Rc8Session::close() {
  SessionResult first;
  auto keep = [&](const CallResult& r) {
    if (!r.ok() && first.ok) first = SessionResult::from(r);
  };
  if (act_.connected()) {
    act_.setReplyTimeout(cfg_.client.reply_timeout_s);
    if (tool_ != 0 && vacuum_ != 0) {
      keep(act_.variablePutValue(vacuum_, Variant::boolean(false)));
      keep(act_.variablePutValue(air_, Variant::boolean(false)));
    }
    if (slave_) keep(act_.robotExecute(robot_, "slvChangeMode", Variant::i4(0)));
    slave_ = false;
    if (arm_taken_) keep(act_.robotExecute(robot_, "GiveArm"));
    arm_taken_ = false;
    if (motor_) keep(act_.robotExecute(robot_, "Motor", Variant::i4(0)));
    motor_ = false;
    if (vacuum_) keep(act_.variableRelease(vacuum_));
    if (air_) keep(act_.variableRelease(air_));
    if (robot_) keep(act_.robotRelease(robot_));
    if (controller_) keep(act_.controllerDisconnect(controller_));
    keep(act_.serviceStop());
  }
  {
    std::lock_guard<PiMutex> lock(watch_mutex_);
    if (watch_.connected()) {
      if (watch_robot_) keep(watch_.robotRelease(watch_robot_));
      if (watch_controller_) keep(watch_.controllerDisconnect(watch_controller_));
      keep(watch_.serviceStop());
    }
  }
  abort();
  return first;
}

void Rc8Session::abort() {
  act_.close();
  {
    std::lock_guard<PiMutex> lock(watch_mutex_);
    watch_.close();
    watch_controller_ = watch_robot_ = 0;
  }
  act_.setReplyTimeout(cfg_.client.reply_timeout_s);
  controller_ = robot_ = vacuum_ = air_ = 0;
  open_ = false;
  slave_ = false;
  motor_ = false;
  arm_taken_ = false;
  tool_ = -1;
}

}  // namespace depowder::robot
