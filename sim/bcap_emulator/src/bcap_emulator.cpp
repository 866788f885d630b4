#include "depowder/sim/bcap_emulator.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <pthread.h>
#include <sched.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>

#include "depowder/robot/bcap/client.hpp"

namespace depowder::sim {

using robot::bcap::Packet;
using robot::bcap::Variant;
namespace hr = robot::bcap::hr;
namespace bcap = robot::bcap;

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = 180.0 / kPi;

std::int64_t nowNs() { return bcap::monotonicNs(); }
using bcap::sleepUntilNs;

bool sendAll(int fd, const std::vector<std::uint8_t>& bytes) {
  std::size_t sent = 0;
  while (sent < bytes.size()) {
    const ssize_t n = ::send(fd, bytes.data() + sent, bytes.size() - sent, MSG_NOSIGNAL);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    sent += static_cast<std::size_t>(n);
  }
  return true;
}

// The first integer of a scalar or an array ("Motor" accepts 1 and [1, 0]).
std::optional<std::int64_t> firstInt(const Variant& v) {
  if (auto i = v.asInt()) return i;
  if (v.array && v.isInteger() && !v.ints.empty()) return v.ints[0];
  return std::nullopt;
}

}  // namespace

struct BcapEmulator::Connection {
  int fd = -1;
  int id = 0;
  std::thread thread;
  std::atomic<bool> done{false};
};

BcapEmulator::BcapEmulator(BcapEmulatorConfig config) : config_(std::move(config)) {
  q_ = config_.q_initial;
  io_[config_.vacuum_variable] = false;
  io_[config_.air_variable] = false;
}

BcapEmulator::~BcapEmulator() { stop(); }

bool BcapEmulator::start(std::string* error) {
  auto fail = [&](const std::string& why) {
    if (error) *error = "b-CAP emulator on " + config_.bind_address + ":" + std::to_string(config_.port) + ": " + why;
    if (listen_fd_ >= 0) ::close(listen_fd_);
    listen_fd_ = -1;
    return false;
  };
  if (running_) return true;
  listen_fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (listen_fd_ < 0) return fail(std::strerror(errno));
  const int one = 1;
  setsockopt(listen_fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<std::uint16_t>(config_.port));
  if (inet_pton(AF_INET, config_.bind_address.c_str(), &addr.sin_addr) != 1)
    return fail("bind_address is not an IPv4 address");
  if (::bind(listen_fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) < 0) return fail(std::strerror(errno));
  if (::listen(listen_fd_, 8) < 0) return fail(std::strerror(errno));
  socklen_t len = sizeof addr;
  getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&addr), &len);
  bound_port_ = ntohs(addr.sin_port);
  running_ = true;
  accept_thread_ = std::thread([this] { acceptLoop(); });
  return true;
}

void BcapEmulator::stop() {
  if (!running_.exchange(false)) return;
  if (accept_thread_.joinable()) accept_thread_.join();
  if (listen_fd_ >= 0) ::close(listen_fd_);
  listen_fd_ = -1;
  std::vector<std::shared_ptr<Connection>> conns;
  {
    std::lock_guard<std::mutex> lock(connections_mutex_);
    for (auto& c : connections_) {
      if (c->fd >= 0) ::shutdown(c->fd, SHUT_RDWR);
    }
    conns.swap(connections_);
  }
  for (auto& c : conns) {
    if (c->thread.joinable()) c->thread.join();
  }
}

void BcapEmulator::acceptLoop() {
  while (running_) {
    pollfd p{listen_fd_, POLLIN, 0};
    if (::poll(&p, 1, 50) <= 0) continue;
    const int fd = ::accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC);
    if (fd < 0) continue;
    std::lock_guard<std::mutex> lock(connections_mutex_);
    // Reap finished connections.
    for (auto it = connections_.begin(); it != connections_.end();) {
      if ((*it)->done) {
        if ((*it)->thread.joinable()) (*it)->thread.join();
        it = connections_.erase(it);
      } else {
        ++it;
      }
    }
    if (static_cast<int>(connections_.size()) >= config_.max_connections) {
      ::close(fd);
      continue;
    }
    const int one = 1;
    setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    auto conn = std::make_shared<Connection>();
    conn->fd = fd;
    conn->id = next_connection_++;
    {
      std::lock_guard<PiMutex> state(mutex_);
      ++stats_.connections;
    }
    conn->thread = std::thread([this, conn] { serve(conn); });
    if (config_.realtime) {
      // The controller's cycle should not wait behind the simulator's rendering.
      sched_param sp{};
      sp.sched_priority = 49;
      pthread_setschedparam(conn->thread.native_handle(), SCHED_FIFO, &sp);
    }
    connections_.push_back(conn);
  }
}

void BcapEmulator::serve(std::shared_ptr<Connection> conn) {
  std::vector<std::uint8_t> buf;
  bool open = true;
  const PartialReply partial = [&](const Packet& p) { open = open && sendAll(conn->fd, bcap::encode(p)); };
  while (open && running_) {
    pollfd p{conn->fd, POLLIN, 0};
    const int rc = ::poll(&p, 1, 100);
    if (rc < 0 && errno != EINTR) break;
    if (rc <= 0) continue;
    std::uint8_t chunk[4096];
    const ssize_t n = ::recv(conn->fd, chunk, sizeof chunk, 0);
    if (n <= 0) {
      if (n < 0 && errno == EINTR) continue;
      break;
    }
    buf.insert(buf.end(), chunk, chunk + n);
    while (open && !buf.empty()) {
      const bcap::DecodeResult d = bcap::decode(buf);
      if (d.status == bcap::DecodeStatus::Incomplete) break;
      if (d.status == bcap::DecodeStatus::Ok) {
        {
          std::lock_guard<PiMutex> lock(mutex_);
          ++stats_.packets;
        }
        const Packet rep = handle(d.packet, conn->id, partial);
        open = open && sendAll(conn->fd, bcap::encode(rep));
        buf.erase(buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(d.size));
        continue;
      }
      // Invalid. If the frame itself is sound (header, length, footer) answer with an error
      // and carry on; otherwise the stream cannot be re-synchronised: close it.
      {
        std::lock_guard<PiMutex> lock(mutex_);
        ++stats_.malformed;
        stats_.last_error = "malformed request: " + d.error;
      }
      const bool framed = d.size >= bcap::kMinPacketSize && buf.size() >= d.size && buf[0] == bcap::kHeader &&
                          buf[d.size - 1] == bcap::kFooter;
      if (!framed) {
        open = false;
        break;
      }
      Packet rep;
      rep.serial = static_cast<std::uint16_t>(buf[5] | (buf[6] << 8));
      rep.id = hr::E_INVALIDPACKET;
      {
        std::lock_guard<PiMutex> lock(mutex_);
        ++stats_.error_replies;
      }
      open = sendAll(conn->fd, bcap::encode(rep));
      buf.erase(buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(d.size));
    }
  }
  {
    // Under the lock so that stop() / dropConnections() never touch a closed (reused) fd.
    std::lock_guard<std::mutex> lock(connections_mutex_);
    ::shutdown(conn->fd, SHUT_RDWR);
    ::close(conn->fd);
    conn->fd = -1;
  }
  connectionClosed(conn->id);
  conn->done = true;
}

void BcapEmulator::connectionClosed(int connection) {
  std::lock_guard<PiMutex> lock(mutex_);
  wdt_s_.erase(connection);
  if (arm_owner_ == connection) {
    // A client that vanishes in slave mode stops the arm, as a real controller's watchdog does.
    if (slave_mode_ != 0) stopArmLocked(false);
    arm_owner_ = 0;
  }
  for (auto it = handles_.begin(); it != handles_.end();) {
    it = it->second.connection == connection ? handles_.erase(it) : std::next(it);
  }
}

// ---- accessors ----------------------------------------------------------------------------------

EmulatorJointState BcapEmulator::joints() const {
  std::lock_guard<PiMutex> lock(mutex_);
  EmulatorJointState s;
  s.q = q_;
  const bool moving = slave_mode_ != 0 && last_move_ns_ != 0 &&
                      nowNs() - last_move_ns_ < static_cast<std::int64_t>(2.5 * config_.cycle_s * 1e9);
  if (moving) s.qd = qd_;
  s.motor_on = motor_on_;
  s.slave_mode = slave_mode_ != 0;
  s.slave_moves = slave_moves_;
  return s;
}

EmulatorToolState BcapEmulator::tool() const {
  std::lock_guard<PiMutex> lock(mutex_);
  EmulatorToolState t;
  auto v = io_.find(config_.vacuum_variable);
  auto a = io_.find(config_.air_variable);
  t.vacuum = v != io_.end() && v->second;
  t.air = a != io_.end() && a->second;
  return t;
}

bool BcapEmulator::halted() const {
  std::lock_guard<PiMutex> lock(mutex_);
  return halted_;
}

std::optional<std::chrono::steady_clock::time_point> BcapEmulator::lastHaltTime() const {
  std::lock_guard<PiMutex> lock(mutex_);
  return halt_time_;
}

EmulatorStats BcapEmulator::stats() const {
  std::lock_guard<PiMutex> lock(mutex_);
  return stats_;
}

bool BcapEmulator::setJoints(const robot::Joints& q) {
  std::lock_guard<PiMutex> lock(mutex_);
  if (slave_mode_ != 0) return false;
  q_ = q;
  qd_ = {};
  return true;
}

void BcapEmulator::raiseError(const std::string& why) {
  std::lock_guard<PiMutex> lock(mutex_);
  stopArmLocked(true);
  error_pending_ = true;
  stats_.last_error = "raised: " + why;
}

void BcapEmulator::dropConnections() {
  std::lock_guard<std::mutex> lock(connections_mutex_);
  for (auto& c : connections_) {
    if (c->fd >= 0) ::shutdown(c->fd, SHUT_RDWR);
  }
}

// ---- requests -----------------------------------------------------------------------------------

Packet BcapEmulator::reply(const Packet& req, std::uint32_t hresult, std::vector<Variant> values) {
  Packet rep;
  rep.serial = req.serial;
  rep.reserved = req.reserved;
  rep.id = hresult;
  rep.args = std::move(values);
  return rep;
}

Packet BcapEmulator::error(const Packet& req, std::uint32_t hresult, const std::string& why) {
  // Called with mutex_ held or not; stats_ is only touched under the lock.
  stats_.error_replies++;
  stats_.last_error = bcap::functionName(req.id) + ": " + why + " -> " + bcap::describeHresult(hresult);
  if (hresult == hr::E_SLAVE_LATE || hresult == hr::E_JOINT_LIMIT || hresult == hr::E_SPEED_LIMIT)
    stats_.last_refusal = stats_.last_error;
  return reply(req, hresult);
}

std::optional<std::uint32_t> BcapEmulator::handleArg(const Packet& req, std::size_t i, Handle::Kind kind) const {
  if (req.args.size() <= i) return std::nullopt;
  const Variant& v = req.args[i];
  if (v.type != bcap::VT_I4 && v.type != bcap::VT_UI4) return std::nullopt;
  const auto h = v.asInt();
  if (!h) return std::nullopt;
  auto it = handles_.find(static_cast<std::uint32_t>(*h));
  if (it == handles_.end() || it->second.kind != kind) return std::nullopt;
  return static_cast<std::uint32_t>(*h);
}

std::vector<double> BcapEmulator::jointsDegreesLocked() const {
  std::vector<double> deg(8, 0.0);
  for (int i = 0; i < 6; ++i) deg[i] = q_[i] * kDeg;
  return deg;
}

void BcapEmulator::restLocked() {
  qd_ = {};
  on_the_way_.clear();  // the arm stays where it is
  async_targets_.clear();
  last_move_ns_ = 0;
  cycle_origin_ns_ = 0;
}

void BcapEmulator::stopArmLocked(bool motor_off) {
  slave_mode_ = 0;
  restLocked();
  halted_ = true;
  halt_time_ = std::chrono::steady_clock::now();
  if (motor_off) motor_on_ = false;
}

Packet BcapEmulator::handle(const Packet& req, int connection, const PartialReply& partial) {
  auto str = [&](std::size_t i) -> std::optional<std::string> {
    if (req.args.size() <= i) return std::nullopt;
    return req.args[i].asString();
  };
  auto newHandle = [&](Handle::Kind kind, const std::string& name) {
    const std::uint32_t h = next_handle_++;
    handles_[h] = Handle{kind, connection, name};
    return reply(req, hr::S_OK, {Variant::handle(h)});
  };

  if (req.id == bcap::ID_ROBOT_EXECUTE) return robotExecute(req, connection, partial);

  std::lock_guard<PiMutex> lock(mutex_);
  switch (req.id) {
    case bcap::ID_SERVICE_START: {
      // The option: comma-separated "key=value" (DENSO's clients send "WDT=400" or ",WDT=400,...").
      const auto option = req.args.empty() ? std::optional<std::string>("") : str(0);
      if (!option) return error(req, hr::E_INVALIDARG, "the option must be a string");
      wdt_s_.erase(connection);
      std::size_t at = 0;
      while (at <= option->size()) {
        const std::size_t end = std::min(option->find(',', at), option->size());
        std::string item = option->substr(at, end - at);
        item.erase(0, item.find_first_not_of(' '));
        item.erase(item.find_last_not_of(' ') + 1);
        if (item.size() >= 4 && (item.compare(0, 4, "WDT=") == 0 || item.compare(0, 4, "wdt=") == 0)) {
          // A number, all of it: 0 asks for none, else 1 ms (a reply per ms at most) to 60 s.
          const char* first = item.c_str() + 4;
          char* last = nullptr;
          const double ms = std::strtod(first, &last);
          if (last == first || *last != '\0' || !(ms == 0 || (ms >= 1 && ms <= 60000)))
            return error(req, hr::E_INVALIDARG, "the watchdog period '" + item + "' is not 0 or 1 to 60000 ms");
          if (ms > 0) wdt_s_[connection] = ms / 1000;
        }
        at = end + 1;
      }
      return reply(req, hr::S_OK);
    }
    case bcap::ID_SERVICE_STOP:
      wdt_s_.erase(connection);
      return reply(req, hr::S_OK);

    case bcap::ID_CONTROLLER_CONNECT: {
      const auto name = str(0), provider = str(1), machine = str(2), option = str(3);
      if (!name || !provider || !machine || !option || req.args.size() != 4)
        return error(req, hr::E_INVALIDARG, "expects (name, provider, machine, option) strings");
      if (provider->rfind("CaoProv.DENSO.", 0) != 0)
        return error(req, hr::E_INVALIDARG, "unknown provider '" + *provider + "'");
      return newHandle(Handle::Controller, *name);
    }
    case bcap::ID_CONTROLLER_DISCONNECT: {
      const auto h = handleArg(req, 0, Handle::Controller);
      if (!h) return error(req, hr::E_HANDLE, "not a controller handle");
      handles_.erase(*h);
      return reply(req, hr::S_OK);
    }
    case bcap::ID_CONTROLLER_GETROBOT: {
      const auto name = str(1);
      if (!handleArg(req, 0, Handle::Controller)) return error(req, hr::E_HANDLE, "not a controller handle");
      if (!name) return error(req, hr::E_INVALIDARG, "robot name must be a string");
      return newHandle(Handle::Robot, *name);
    }
    case bcap::ID_CONTROLLER_GETVARIABLE: {
      const auto name = str(1);
      if (!handleArg(req, 0, Handle::Controller)) return error(req, hr::E_HANDLE, "not a controller handle");
      if (!name) return error(req, hr::E_INVALIDARG, "variable name must be a string");
      // I/O variables: "IO" followed by a number.
      const bool io = name->size() > 2 && name->compare(0, 2, "IO") == 0 &&
                      std::all_of(name->begin() + 2, name->end(), [](char c) { return c >= '0' && c <= '9'; });
      if (!io) return error(req, hr::E_INVALIDARG, "unknown variable '" + *name + "' (only IO<n>)");
      io_.emplace(*name, false);
      return newHandle(Handle::Variable, *name);
    }
    case bcap::ID_CONTROLLER_EXECUTE: {
      const auto cmd = str(1);
      if (!handleArg(req, 0, Handle::Controller)) return error(req, hr::E_HANDLE, "not a controller handle");
      if (!cmd) return error(req, hr::E_INVALIDARG, "command must be a string");
      if (*cmd == "ClearError") {
        error_pending_ = false;
        return reply(req, hr::S_OK, {Variant::empty()});
      }
      return error(req, hr::E_NOTIMPL, "Controller_Execute '" + *cmd + "' is not emulated");
    }
    case bcap::ID_ROBOT_HALT: {
      if (!handleArg(req, 0, Handle::Robot)) return error(req, hr::E_HANDLE, "not a robot handle");
      ++stats_.halts;
      stopArmLocked(false);
      return reply(req, hr::S_OK);
    }
    case bcap::ID_ROBOT_RELEASE: {
      const auto h = handleArg(req, 0, Handle::Robot);
      if (!h) return error(req, hr::E_HANDLE, "not a robot handle");
      if (arm_owner_ == connection) {
        if (slave_mode_ != 0) stopArmLocked(false);
        arm_owner_ = 0;
      }
      handles_.erase(*h);
      return reply(req, hr::S_OK);
    }
    case bcap::ID_VARIABLE_GETVALUE: {
      const auto h = handleArg(req, 0, Handle::Variable);
      if (!h) return error(req, hr::E_HANDLE, "not a variable handle");
      return reply(req, hr::S_OK, {Variant::boolean(io_[handles_[*h].name])});
    }
    case bcap::ID_VARIABLE_PUTVALUE: {
      const auto h = handleArg(req, 0, Handle::Variable);
      if (!h) return error(req, hr::E_HANDLE, "not a variable handle");
      if (req.args.size() != 2) return error(req, hr::E_INVALIDARG, "expects (handle, value)");
      const auto v = req.args[1].asInt();
      if (!v) return error(req, hr::E_INVALIDARG, "an I/O value must be BOOL or an integer");
      if (io_refusals_ > 0 && io_refusals_-- > 0) return error(req, hr::E_ACCESSDENIED, "I/O write refused");
      io_[handles_[*h].name] = *v != 0;
      return reply(req, hr::S_OK);
    }
    case bcap::ID_VARIABLE_RELEASE: {
      const auto h = handleArg(req, 0, Handle::Variable);
      if (!h) return error(req, hr::E_HANDLE, "not a variable handle");
      handles_.erase(*h);
      return reply(req, hr::S_OK);
    }
    default:
      return error(req, hr::E_NOTIMPL, "not emulated");
  }
}

Packet BcapEmulator::robotExecute(const Packet& req, int connection, const PartialReply& partial) {
  std::unique_lock<PiMutex> lock(mutex_);
  if (req.args.size() != 3 && req.args.size() != 2)
    return error(req, hr::E_INVALIDARG, "expects (robot, command, parameter)");
  if (!handleArg(req, 0, Handle::Robot)) return error(req, hr::E_HANDLE, "not a robot handle");
  const auto cmd = req.args[1].asString();
  if (!cmd) return error(req, hr::E_INVALIDARG, "command must be a string");
  const Variant param = req.args.size() == 3 ? req.args[2] : Variant::empty();

  if (*cmd == "slvMove") {
    lock.unlock();
    return slvMove(req, connection, param);
  }
  if (*cmd == "CurJnt") return reply(req, hr::S_OK, {Variant::r8Array(jointsDegreesLocked())});
  if (*cmd == "ExtSpeed") return reply(req, hr::S_OK, {Variant::empty()});
  if (*cmd == "slvSendFormat" || *cmd == "slvRecvFormat") {
    // Only the joint formats are emulated: commands of joints alone (send 0), replies of joints alone (2).
    const auto v = firstInt(param);
    if (v && (*v == 0 || (*cmd == "slvRecvFormat" && *v == 2))) {
      (*cmd == "slvSendFormat" ? stats_.send_format : stats_.recv_format) = static_cast<int>(*v);
      return reply(req, hr::S_OK, {Variant::empty()});
    }
    return error(req, hr::E_NOTIMPL, *cmd + " other than the default is not emulated");
  }
  if (*cmd == "TakeArm") {
    if (arm_owner_ != 0 && arm_owner_ != connection) return error(req, hr::E_ARM_BUSY, "TakeArm");
    arm_owner_ = connection;
    return reply(req, hr::S_OK, {Variant::empty()});
  }
  if (*cmd == "GiveArm") {
    if (arm_owner_ != connection) return error(req, hr::E_ARM_NOT_TAKEN, "GiveArm");
    if (slave_mode_ != 0) stopArmLocked(false);
    arm_owner_ = 0;
    return reply(req, hr::S_OK, {Variant::empty()});
  }
  if (*cmd == "Motor") {
    const auto v = firstInt(param);
    if (!v || (*v != 0 && *v != 1)) return error(req, hr::E_INVALIDARG, "Motor expects 0 or 1");
    if (*v == 0) {
      if (slave_mode_ != 0) stopArmLocked(true);
      motor_on_ = false;
      return reply(req, hr::S_OK, {Variant::empty()});
    }
    if (error_pending_) return error(req, hr::E_CONTROLLER_ERROR, "Motor 1");
    // Counted, not refused: DENSO's samples and drivers take the arm before Motor 1, but whether
    // an RC8 refuses the other order is not known here.
    if (arm_owner_ != connection) ++stats_.motor_on_untaken;
    if (!motor_on_) {
      // Servo power-up takes a while: "still executing" replies every WDT until it is done.
      const auto wdt = wdt_s_.find(connection);
      const std::int64_t period_ns = wdt == wdt_s_.end() ? 0 : static_cast<std::int64_t>(wdt->second * 1e9);
      lock.unlock();
      const std::int64_t start = nowNs(), end = start + static_cast<std::int64_t>(config_.motor_on_time_s * 1e9);
      if (period_ns > 0)
        for (std::int64_t next = start + period_ns; next < end; next += period_ns) {
          sleepUntilNs(next);
          if (partial) partial(reply(req, hr::S_EXECUTING));
        }
      sleepUntilNs(end);
      lock.lock();
      if (error_pending_) return error(req, hr::E_CONTROLLER_ERROR, "Motor 1");
      motor_on_ = true;
    }
    return reply(req, hr::S_OK, {Variant::empty()});
  }
  if (*cmd == "slvChangeMode") {
    const auto v = firstInt(param);
    if (!v) return error(req, hr::E_INVALIDARG, "slvChangeMode expects an integer mode");
    if (arm_owner_ != connection) return error(req, hr::E_ARM_NOT_TAKEN, "slvChangeMode");
    if (*v == 0) {
      const bool moving = last_move_ns_ != 0 &&
                          nowNs() - last_move_ns_ < static_cast<std::int64_t>(2.5 * config_.cycle_s * 1e9) &&
                          std::any_of(qd_.begin(), qd_.end(), [](double x) { return std::abs(x) > 1e-6; });
      if (moving) ++stats_.abrupt_exits;
      slave_mode_ = 0;
      restLocked();
      return reply(req, hr::S_OK, {Variant::empty()});
    }
    const std::int64_t kind = *v & 0xFF, sync = *v & ~0xFF;
    if (kind < 1 || kind > 3 || (sync != 0 && sync != 0x100 && sync != 0x200))
      return error(req, hr::E_INVALIDARG, "slave mode " + std::to_string(*v) + " does not exist");
    if (kind != 2) return error(req, hr::E_NOTIMPL, "only joint (J) slave modes are emulated");
    if (error_pending_) return error(req, hr::E_CONTROLLER_ERROR, "slvChangeMode");
    if (!motor_on_) return error(req, hr::E_MOTOR_OFF, "slvChangeMode");
    slave_mode_ = static_cast<int>(*v);
    halted_ = false;
    restLocked();
    return reply(req, hr::S_OK, {Variant::empty()});
  }
  return error(req, hr::E_NOTIMPL, "Robot_Execute '" + *cmd + "' is not emulated");
}

Packet BcapEmulator::slvMove(const Packet& req, int connection, const Variant& param) {
  const std::int64_t arrival = nowNs();
  const std::int64_t cycle_ns = static_cast<std::int64_t>(config_.cycle_s * 1e9);
  std::unique_lock<PiMutex> lock(mutex_);
  if (error_pending_) return error(req, hr::E_CONTROLLER_ERROR, "slvMove");
  if (slave_mode_ == 0) return error(req, halted_ ? hr::E_HALTED : hr::E_NOT_SLAVE_MODE, "slvMove");
  if (arm_owner_ != connection) return error(req, hr::E_ARM_NOT_TAKEN, "slvMove");
  const bool sync = (slave_mode_ & 0x200) != 0;

  // The late-command error: in sync mode the next command must come within late_limit_s of the
  // previous one's reply. A real RC8 replies on its cycle; this emulator's reply leaves later when
  // its own host stalls it (the thread wakes late), and that delay is not the client's: the
  // client's time runs from the reply.
  if (sync && last_move_ns_ != 0 && arrival - last_reply_ns_ > static_cast<std::int64_t>(config_.late_limit_s * 1e9)) {
    const std::string why = "slvMove " + std::to_string((arrival - last_reply_ns_) / 1000) +
                            " us after the previous reply (which left " +
                            std::to_string((last_reply_ns_ - last_move_ns_) / 1000) + " us after its cycle)";
    ++stats_.late_errors;
    stopArmLocked(true);
    error_pending_ = true;
    return error(req, hr::E_SLAVE_LATE, why);
  }

  // 6..8 joint angles, or DENSO's own driver's form: the 8 joints and an option word of 0
  // (denso_robot_core's CreateSendParameter, "Number of joints + option").
  const auto values = (param.array && param.isReal()) ? param.asReals() : std::nullopt;
  if (!values || values->size() < 6 || values->size() > 9)
    return error(req, hr::E_INVALIDARG,
                 "slvMove expects an R8/R4 array of 6..8 joint angles (deg), or 8 and an option");
  if (values->size() == 9 && (*values)[8] != 0.0)
    return error(req, hr::E_INVALIDARG,
                 "slvMove option word " + std::to_string((*values)[8]) + " is not supported (only 0)");
  robot::Joints target;
  for (std::size_t i = 0; i < values->size(); ++i) {
    if (!std::isfinite((*values)[i])) return error(req, hr::E_INVALIDARG, "slvMove target is not finite");
  }
  for (int i = 0; i < 6; ++i) {
    target[i] = (*values)[i] / kDeg;
    if (target[i] < config_.q_min[i] - 1e-9 || target[i] > config_.q_max[i] + 1e-9) {
      ++stats_.limit_errors;
      return error(req, hr::E_JOINT_LIMIT,
                   "J" + std::to_string(i + 1) + " target " + std::to_string((*values)[i]) + " deg outside its limits");
    }
  }
  // A target is checked against the one the client commanded a cycle before. In sync mode that is
  // the previous target (one per cycle). In async mode commands take effect as they come, so a
  // burst within one cycle is one step: from the target in effect a cycle ago (or from where the
  // arm was when the burst began).
  const robot::Joints previous = on_the_way_.empty() ? q_ : on_the_way_.back();
  robot::Joints reference = previous;
  std::int64_t since_ns = cycle_ns;
  if (!sync) {
    while (async_targets_.size() >= 2 && arrival - async_targets_[1].at_ns >= cycle_ns) async_targets_.pop_front();
    if (!async_targets_.empty()) {
      const AsyncTarget& first = async_targets_.front();
      const bool settled = arrival - first.at_ns >= cycle_ns;
      reference = settled ? first.target : first.before;
      if (!settled) since_ns = arrival - first.at_ns;
    }
  }
  for (int i = 0; i < 6; ++i) {
    const double step = std::abs(target[i] - reference[i]);
    if (step > config_.qd_max[i] * config_.cycle_s * config_.speed_margin) {
      ++stats_.speed_errors;
      stopArmLocked(true);
      error_pending_ = true;
      const std::string in = since_ns >= cycle_ns ? "one cycle" : std::to_string(since_ns / 1000) + " us";
      return error(req, hr::E_SPEED_LIMIT,
                   "J" + std::to_string(i + 1) + " step " + std::to_string(step * kDeg) + " deg in " + in);
    }
  }
  if (!sync) async_targets_.push_back({arrival, target, previous});

  std::int64_t apply_at = arrival;
  if (sync) {
    // Sync-wait: the command takes effect, and the reply goes out, at the next control cycle.
    if (cycle_origin_ns_ == 0) {
      cycle_origin_ns_ = arrival;
    } else {
      const std::int64_t k = (arrival - cycle_origin_ns_ + cycle_ns - 1) / cycle_ns;
      apply_at = std::max(cycle_origin_ns_ + k * cycle_ns, last_move_ns_ + cycle_ns);
    }
    lock.unlock();
    sleepUntilNs(apply_at + reply_stall_ns_.load());
    lock.lock();
    if (slave_mode_ == 0) return error(req, halted_ ? hr::E_HALTED : hr::E_NOT_SLAVE_MODE, "slvMove (stopped)");
  }
  const double dt = last_move_ns_ != 0 ? static_cast<double>(apply_at - last_move_ns_) * 1e-9 : config_.cycle_s;
  // The arm reaches the target servo_lag_cycles later.
  on_the_way_.push_back(target);
  robot::Joints reached = q_;
  if (static_cast<int>(on_the_way_.size()) > config_.servo_lag_cycles) {
    reached = on_the_way_.front();
    on_the_way_.pop_front();
  }
  for (int i = 0; i < 6; ++i) qd_[i] = (reached[i] - q_[i]) / std::max(dt, 1e-6);
  q_ = reached;
  last_move_ns_ = apply_at;
  last_reply_ns_ = nowNs();
  ++slave_moves_;
  return reply(req, hr::S_OK, {Variant::r8Array(jointsDegreesLocked())});
}

}  // namespace depowder::sim
