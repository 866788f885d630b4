// A b-CAP client over TCP: one request at a time, serial numbers, reply timeouts, "still
// executing" (0x900) replies waited out, and a clear error for every failure. A request is never
// sent twice: TCP loses nothing, and the controller would run a repeated request again (DENSO's
// clients allow no retry over TCP; its server de-duplicates only over UDP).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "depowder/robot/bcap/packet.hpp"

namespace depowder::robot::bcap {

struct ClientConfig {
  std::string host = "127.0.0.1";   ///< controller address (IPv4 dotted quad or host name)
  int port = 5007;                  ///< b-CAP TCP port
  double connect_timeout_s = 1.0;   ///< s, TCP connect
  double reply_timeout_s = 1.0;     ///< s, wait for a reply (or a "still executing" one) before giving up
  double executing_timeout_s = 20;  ///< s, total wait while the controller keeps answering 0x900
};

enum class CallStatus {
  Ok,
  NotConnected,     ///< connect() was not called or the connection was closed
  ConnectFailed,    ///< TCP connect refused / timed out
  Timeout,          ///< no reply within the reply timeout
  Disconnected,     ///< the controller closed the connection or a socket error occurred
  ProtocolError,    ///< the reply was not a valid b-CAP packet (the connection is closed)
  ControllerError,  ///< the controller answered with a failure HRESULT (see hresult)
};

const char* toString(CallStatus s);

struct CallResult {
  CallStatus status = CallStatus::NotConnected;
  std::uint32_t hresult = 0;    ///< the reply's HRESULT (ControllerError / Ok)
  std::vector<Variant> values;  ///< return values of the reply
  std::string error;            ///< "Robot_Execute(slvMove): 0x84204077 (...)" etc., empty when Ok
  bool ok() const { return status == CallStatus::Ok; }
  /// values[0] as a handle (I4 or UI4), if present.
  std::optional<std::uint32_t> handle() const;
};

class Client {
 public:
  explicit Client(ClientConfig config = {});
  ~Client();
  Client(const Client&) = delete;
  Client& operator=(const Client&) = delete;

  /// Opens the TCP connection (closing any previous one).
  CallResult connect();
  void close();
  bool connected() const { return fd_ >= 0; }
  const ClientConfig& config() const { return config_; }
  /// Changes the reply timeout (the slave loop uses a short one).
  void setReplyTimeout(double reply_timeout_s) { config_.reply_timeout_s = reply_timeout_s; }

  /// Sends one request and waits for its reply. `what` names the call in errors (e.g.
  /// "slvMove"); the function name is used when empty.
  CallResult call(std::uint32_t function, const std::vector<Variant>& args, const std::string& what = "");

  /// The serial number the next request will carry (1..0xFFFF, never 0).
  /// Replies discarded because their serial did not match (late replies to timed-out requests).
  std::int64_t staleReplies() const { return stale_replies_; }
  /// "Still executing" replies seen.
  std::int64_t executingReplies() const { return executing_replies_; }

  // Typed calls of the session in REFERENCE.md. Handles go out as VT_I4, as DENSO's b-CAP C
  // client library sends them (and as the controller returns them).
  /// `option`: e.g. "WDT=400", the controller then answers "still executing" every 400 ms while a
  /// call runs (without it, DENSO's server sends none and a long call looks like a lost controller).
  CallResult serviceStart(const std::string& option = "");
  CallResult serviceStop();
  CallResult controllerConnect(const std::string& name, const std::string& provider, const std::string& machine,
                               const std::string& option);
  CallResult controllerDisconnect(std::uint32_t controller);
  CallResult controllerGetRobot(std::uint32_t controller, const std::string& name, const std::string& option = "");
  CallResult controllerGetVariable(std::uint32_t controller, const std::string& name, const std::string& option = "");
  CallResult controllerExecute(std::uint32_t controller, const std::string& command,
                               const Variant& param = Variant::empty());
  CallResult robotExecute(std::uint32_t robot, const std::string& command, const Variant& param = Variant::empty());
  CallResult robotHalt(std::uint32_t robot, const std::string& option = "");
  CallResult robotRelease(std::uint32_t robot);
  CallResult variableGetValue(std::uint32_t variable);
  CallResult variablePutValue(std::uint32_t variable, const Variant& value);
  CallResult variableRelease(std::uint32_t variable);

  /// The argument lists of the typed calls, exposed so tests can compare them with hand-built packets.
  static std::vector<Variant> robotExecuteArgs(std::uint32_t robot, const std::string& command, const Variant& param);

 private:
  CallResult fail(CallStatus status, const std::string& what, const std::string& why);
  bool sendAll(const std::vector<std::uint8_t>& bytes, std::string* why);
  /// Reads until one whole packet is buffered or `deadline_ns` (CLOCK_MONOTONIC) passes.
  enum class ReadOutcome { Packet, Timeout, Closed, Invalid };
  ReadOutcome readPacket(std::int64_t deadline_ns, Packet* out, std::string* why);

  ClientConfig config_;
  int fd_ = -1;
  std::uint16_t serial_ = 1;
  std::vector<std::uint8_t> buffer_;
  std::int64_t stale_replies_ = 0;
  std::int64_t executing_replies_ = 0;
};

/// CLOCK_MONOTONIC now, nanoseconds.
std::int64_t monotonicNs();
/// Sleeps until CLOCK_MONOTONIC reaches t (ns; absolute, so a cycle's lateness does not add up).
void sleepUntilNs(std::int64_t t);

}  // namespace depowder::robot::bcap
