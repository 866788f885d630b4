// Publishes HEARTBEAT (2 Hz by default) with the bus counters, CPU and memory, the process's
// figures and its uptime_s (seconds on the steady clock since it started).
#pragma once

#include <cstdint>
#include <map>
#include <string>

#include "depowder/heartbeat_t.hpp"
#include "depowder/node/bus.hpp"

namespace depowder::node {

class Heartbeat {
 public:
  Heartbeat(Bus& bus, std::string process, double period_s = 0.5);

  void setState(std::int8_t state, std::string reason = "");
  /// A process-specific figure, published with the next heartbeats.
  void setStat(const std::string& name, double value) { stats_[name] = value; }
  /// Counts an input the process did not handle (overrun, stale, invalid).
  void addDropped(std::int64_t n = 1) { dropped_ += n; }
  std::int64_t dropped() const { return dropped_; }

  /// Publishes if the period has passed since the last one (call it from the main loop).
  void tick();
  /// Publishes now.
  void publish();

 private:
  Bus& bus_;
  heartbeat_t msg_;
  double period_s_;
  std::int64_t start_ = 0;         ///< node::steadyUtime when the process started its heartbeat
  std::int64_t last_publish_ = 0;  ///< node::steadyUtime of the last heartbeat (0: none yet)
  double last_cpu_s_ = 0;
  std::int64_t dropped_ = 0;
  std::map<std::string, double> stats_;
};

/// The stat `name` of a heard heartbeat, NaN if it has none.
double heartbeatStat(const heartbeat_t& h, const std::string& name);

/// Host name of this machine.
std::string hostName();

/// CPU time (user + system) of this process so far, seconds; peak resident set, kB.
double processCpuSeconds();
std::int64_t peakRssKb();

}  // namespace depowder::node
