#include "depowder/robot/bcap/client.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <ctime>

namespace depowder::robot::bcap {

namespace {

std::string fixedSeconds(double s) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g s", s);
  return buf;
}

}  // namespace

std::int64_t monotonicNs() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1000000000LL + ts.tv_nsec;
}

void sleepUntilNs(std::int64_t t) {
  timespec ts{static_cast<time_t>(t / 1000000000LL), static_cast<long>(t % 1000000000LL)};
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
}

const char* toString(CallStatus s) {
  switch (s) {
    case CallStatus::Ok:
      return "ok";
    case CallStatus::NotConnected:
      return "not connected";
    case CallStatus::ConnectFailed:
      return "connect failed";
    case CallStatus::Timeout:
      return "timeout";
    case CallStatus::Disconnected:
      return "disconnected";
    case CallStatus::ProtocolError:
      return "protocol error";
    case CallStatus::ControllerError:
      return "controller error";
  }
  return "?";
}

std::optional<std::uint32_t> CallResult::handle() const {
  if (values.empty()) return std::nullopt;
  const auto v = values[0].asInt();
  if (!v || (values[0].type != VT_I4 && values[0].type != VT_UI4)) return std::nullopt;
  return static_cast<std::uint32_t>(*v);
}

Client::Client(ClientConfig config) : config_(std::move(config)) {}
Client::~Client() { close(); }

void Client::close() {
  if (fd_ >= 0) {
    ::shutdown(fd_, SHUT_RDWR);
    ::close(fd_);
  }
  fd_ = -1;
  buffer_.clear();
}

CallResult Client::fail(CallStatus status, const std::string& what, const std::string& why) {
  CallResult r;
  r.status = status;
  r.error = what + ": " + why;
  return r;
}

CallResult Client::connect() {
  close();
  const std::string where = "b-CAP connect to " + config_.host + ":" + std::to_string(config_.port);
  addrinfo hints{};
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* res = nullptr;
  const int gai = getaddrinfo(config_.host.c_str(), std::to_string(config_.port).c_str(), &hints, &res);
  if (gai != 0 || res == nullptr) return fail(CallStatus::ConnectFailed, where, gai_strerror(gai));
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
  if (fd < 0) {
    freeaddrinfo(res);
    return fail(CallStatus::ConnectFailed, where, std::strerror(errno));
  }
  int rc = ::connect(fd, res->ai_addr, res->ai_addrlen);
  freeaddrinfo(res);
  if (rc < 0 && errno != EINPROGRESS) {
    const std::string why = std::strerror(errno);
    ::close(fd);
    return fail(CallStatus::ConnectFailed, where, why);
  }
  if (rc < 0) {
    pollfd p{fd, POLLOUT, 0};
    rc = ::poll(&p, 1, static_cast<int>(config_.connect_timeout_s * 1000));
    int err = 0;
    socklen_t len = sizeof err;
    if (rc <= 0) {
      ::close(fd);
      return fail(CallStatus::ConnectFailed, where, rc == 0 ? "timed out" : std::strerror(errno));
    }
    getsockopt(fd, SOL_SOCKET, SO_ERROR, &err, &len);
    if (err != 0) {
      ::close(fd);
      return fail(CallStatus::ConnectFailed, where, std::strerror(err));
    }
  }
  // Small request/reply packets every 8 ms: never wait for Nagle.
  const int one = 1;
  setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  fd_ = fd;
  CallResult ok;
  ok.status = CallStatus::Ok;
  return ok;
}

bool Client::sendAll(const std::vector<std::uint8_t>& bytes, std::string* why) {
  std::size_t sent = 0;
  const std::int64_t deadline = monotonicNs() + static_cast<std::int64_t>(config_.reply_timeout_s * 1e9);
  while (sent < bytes.size()) {
    const ssize_t n = ::send(fd_, bytes.data() + sent, bytes.size() - sent, MSG_NOSIGNAL);
    if (n > 0) {
      sent += static_cast<std::size_t>(n);
      continue;
    }
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR)) {
      const std::int64_t left_ms = (deadline - monotonicNs()) / 1000000;
      if (left_ms <= 0) {
        *why = "send timed out";
        return false;
      }
      pollfd p{fd_, POLLOUT, 0};
      ::poll(&p, 1, static_cast<int>(left_ms));
      continue;
    }
    *why = std::string("send failed: ") + std::strerror(errno);
    return false;
  }
  return true;
}

Client::ReadOutcome Client::readPacket(std::int64_t deadline_ns, Packet* out, std::string* why) {
  for (;;) {
    // A whole packet may already be buffered.
    if (!buffer_.empty()) {
      const DecodeResult d = decode(buffer_);
      if (d.status == DecodeStatus::Ok) {
        *out = d.packet;
        buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<std::ptrdiff_t>(d.size));
        return ReadOutcome::Packet;
      }
      if (d.status == DecodeStatus::Invalid) {
        *why = "invalid reply: " + d.error;
        return ReadOutcome::Invalid;
      }
    }
    const std::int64_t left_ns = deadline_ns - monotonicNs();
    if (left_ns <= 0) return ReadOutcome::Timeout;
    pollfd p{fd_, POLLIN, 0};
    timespec ts{static_cast<time_t>(left_ns / 1000000000LL), static_cast<long>(left_ns % 1000000000LL)};
    const int rc = ::ppoll(&p, 1, &ts, nullptr);
    if (rc < 0 && errno != EINTR) {
      *why = std::string("poll failed: ") + std::strerror(errno);
      return ReadOutcome::Closed;
    }
    if (rc <= 0) continue;
    std::uint8_t chunk[4096];
    const ssize_t n = ::recv(fd_, chunk, sizeof chunk, 0);
    if (n == 0) {
      *why = "connection closed by the controller";
      return ReadOutcome::Closed;
    }
    if (n < 0) {
      if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) continue;
      *why = std::string("recv failed: ") + std::strerror(errno);
      return ReadOutcome::Closed;
    }
    buffer_.insert(buffer_.end(), chunk, chunk + n);
  }
}

CallResult Client::call(std::uint32_t function, const std::vector<Variant>& args, const std::string& what_in) {
  const std::string what = what_in.empty() ? functionName(function) : functionName(function) + "(" + what_in + ")";
  if (fd_ < 0) return fail(CallStatus::NotConnected, what, "not connected to the controller");

  Packet req;
  req.serial = serial_;
  req.id = function;
  req.args = args;
  std::vector<std::uint8_t> bytes;
  try {
    bytes = encode(req);
  } catch (const std::exception& e) {
    return fail(CallStatus::ProtocolError, what, e.what());
  }
  // The serial advances for every request, whatever its outcome (1..0xFFFF, never 0).
  serial_ = serial_ == 0xFFFF ? 1 : static_cast<std::uint16_t>(serial_ + 1);

  const std::int64_t reply_ns = static_cast<std::int64_t>(config_.reply_timeout_s * 1e9);
  std::int64_t executing_deadline = 0;  // set by the first "still executing" reply
  std::string why;
  if (!sendAll(bytes, &why)) {
    close();
    return fail(CallStatus::Disconnected, what, why);
  }
  std::int64_t deadline = monotonicNs() + reply_ns;
  for (;;) {
    Packet rep;
    const ReadOutcome o = readPacket(deadline, &rep, &why);
    if (o == ReadOutcome::Timeout)
      return fail(CallStatus::Timeout, what,
                  executing_deadline == 0 ? "no reply within " + fixedSeconds(config_.reply_timeout_s)
                                          : "the controller stopped answering while executing");
    if (o == ReadOutcome::Closed) {
      close();
      return fail(CallStatus::Disconnected, what, why);
    }
    if (o == ReadOutcome::Invalid) {
      close();
      return fail(CallStatus::ProtocolError, what, why);
    }
    if (rep.serial != req.serial) {
      ++stale_replies_;  // the late answer to an earlier request that timed out
      continue;
    }
    if (rep.id == hr::S_EXECUTING) {
      // The controller is working on it (ServiceStart's WDT option): each such reply restarts the
      // reply timeout, up to executing_timeout_s in all.
      ++executing_replies_;
      if (executing_deadline == 0)
        executing_deadline = monotonicNs() + static_cast<std::int64_t>(config_.executing_timeout_s * 1e9);
      if (monotonicNs() > executing_deadline)
        return fail(CallStatus::Timeout, what, "still executing after " + fixedSeconds(config_.executing_timeout_s));
      deadline = monotonicNs() + reply_ns;
      continue;
    }
    CallResult r;
    r.hresult = rep.id;
    r.values = std::move(rep.args);
    if (hr::failed(rep.id)) {
      r.status = CallStatus::ControllerError;
      r.error = what + ": " + describeHresult(rep.id);
    } else {
      r.status = CallStatus::Ok;
    }
    return r;
  }
}

// ---- typed calls --------------------------------------------------------------------------------

CallResult Client::serviceStart(const std::string& option) { return call(ID_SERVICE_START, {Variant::bstr(option)}); }
CallResult Client::serviceStop() { return call(ID_SERVICE_STOP, {}); }
CallResult Client::controllerConnect(const std::string& name, const std::string& provider, const std::string& machine,
                                     const std::string& option) {
  return call(ID_CONTROLLER_CONNECT,
              {Variant::bstr(name), Variant::bstr(provider), Variant::bstr(machine), Variant::bstr(option)});
}
CallResult Client::controllerDisconnect(std::uint32_t controller) {
  return call(ID_CONTROLLER_DISCONNECT, {Variant::handle(controller)});
}
CallResult Client::controllerGetRobot(std::uint32_t controller, const std::string& name, const std::string& option) {
  return call(ID_CONTROLLER_GETROBOT, {Variant::handle(controller), Variant::bstr(name), Variant::bstr(option)});
}
CallResult Client::controllerGetVariable(std::uint32_t controller, const std::string& name, const std::string& option) {
  return call(ID_CONTROLLER_GETVARIABLE, {Variant::handle(controller), Variant::bstr(name), Variant::bstr(option)},
              name);
}
CallResult Client::controllerExecute(std::uint32_t controller, const std::string& command, const Variant& param) {
  return call(ID_CONTROLLER_EXECUTE, {Variant::handle(controller), Variant::bstr(command), param}, command);
}
std::vector<Variant> Client::robotExecuteArgs(std::uint32_t robot, const std::string& command, const Variant& param) {
  return {Variant::handle(robot), Variant::bstr(command), param};
}
CallResult Client::robotExecute(std::uint32_t robot, const std::string& command, const Variant& param) {
  return call(ID_ROBOT_EXECUTE, robotExecuteArgs(robot, command, param), command);
}
CallResult Client::robotHalt(std::uint32_t robot, const std::string& option) {
  return call(ID_ROBOT_HALT, {Variant::handle(robot), Variant::bstr(option)});
}
CallResult Client::robotRelease(std::uint32_t robot) { return call(ID_ROBOT_RELEASE, {Variant::handle(robot)}); }
CallResult Client::variableGetValue(std::uint32_t variable) {
  return call(ID_VARIABLE_GETVALUE, {Variant::handle(variable)});
}
CallResult Client::variablePutValue(std::uint32_t variable, const Variant& value) {
  return call(ID_VARIABLE_PUTVALUE, {Variant::handle(variable), value});
}
CallResult Client::variableRelease(std::uint32_t variable) {
  return call(ID_VARIABLE_RELEASE, {Variant::handle(variable)});
}

}  // namespace depowder::robot::bcap
