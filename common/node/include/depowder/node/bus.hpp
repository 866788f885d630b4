// A narrow, typed LCM wrapper for the executables (STYLE: Drake's LCM layer).
// Handlers never throw into LCM's C code: a message that fails to decode is
// counted; an exception from a handler is caught, counted and kept for the
// main loop to report.
#pragma once

#include <cstdint>
#include <functional>
#include <lcm/lcm-cpp.hpp>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

namespace depowder::node {

/// LCM could not start; the message says why and how to fix it.
class BusError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class Bus {
 public:
  struct Counters {
    std::int64_t received = 0;  ///< messages decoded and handled
    std::int64_t published = 0;
    std::int64_t decode_errors = 0;   ///< wrong type, truncated or corrupt
    std::int64_t handler_errors = 0;  ///< handler threw
  };

  /// `url` empty: $LCM_DEFAULT_URL, else LCM's default (udpm, ttl=0). `prefix` is put
  /// in front of every channel name so two cells can share a network.
  explicit Bus(const std::string& url = "", std::string prefix = "");
  ~Bus();
  Bus(const Bus&) = delete;
  Bus& operator=(const Bus&) = delete;

  std::string channel(const std::string& name) const { return prefix_ + name; }
  const std::string& prefix() const { return prefix_; }

  template <class Msg>
  void publish(const std::string& name, const Msg& msg) {
    if (lcm_.publish(channel(name), &msg) == 0) {
      ++counters_.published;
    } else {
      keepError("publish on " + channel(name) + " failed");
    }
  }

  /// Publishes raw bytes (fault injection, relays).
  void publishRaw(const std::string& name, const void* data, int size);

  /// `pattern` is an LCM channel regex without the prefix (e.g. "DEPTH_.*").
  /// The handler gets the decoded message and the full channel name it came on.
  template <class Msg>
  void subscribe(const std::string& pattern, std::function<void(const Msg&, const std::string&)> handler) {
    auto decode = [handler = std::move(handler)](const void* data, int size, const std::string& ch) {
      Msg msg;
      if (msg.decode(data, 0, size) < 0) return false;
      handler(msg, ch);
      return true;
    };
    subscribeRaw(pattern, std::move(decode));
  }

  /// Waits up to timeout_ms for messages and handles them. Returns the number handled
  /// (0 on timeout, and when a signal interrupted the wait or shutdown was requested: the
  /// caller's loop checks shutdownRequested()). Throws BusError if LCM itself fails.
  int spinOnce(int timeout_ms);
  /// Handles the messages that have already arrived, without waiting, up to `max_messages`
  /// (over UDP multicast, those on channels nobody here subscribes to count too). Returns how
  /// many LCM handled.
  /// A node calls it before acting on a deadline, so that nothing already received is taken
  /// for late. Throws BusError if LCM itself fails.
  int drain(int max_messages = 64);

  /// Handles messages until `done()` is true or `seconds` have passed; returns done().
  bool spinUntil(const std::function<bool()>& done, double seconds, int step_ms = 20);

  Counters counters() const;
  /// Errors kept since the last call (decode failures, handler exceptions), oldest first.
  std::vector<std::string> takeErrors();
  int fileno() { return lcm_.getFileno(); }

 private:
  struct Subscription;
  using RawHandler = std::function<bool(const void*, int, const std::string&)>;
  void subscribeRaw(const std::string& pattern, RawHandler handler);
  void keepError(std::string what);

  std::string prefix_;
  lcm::LCM lcm_;
  std::vector<std::unique_ptr<Subscription>> subscriptions_;
  Counters counters_;
  mutable std::mutex errors_mutex_;
  std::vector<std::string> errors_;
};

}  // namespace depowder::node
