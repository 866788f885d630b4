// Helpers for the multi-process test and benchmark: a guard that refuses to send
// multicast outside a private network namespace, and a child process handle.
#pragma once

#include <sys/types.h>

#include <string>
#include <vector>

#include "depowder/stats.hpp"  // percentile, for the tests and the bench

namespace depowder::perception::testing {

/// True when this process sees no network interface but loopback (as inside test/netns-run),
/// so udpm multicast cannot reach a real interface. `why` lists the interfaces otherwise.
bool inPrivateNetwork(std::string* why = nullptr);

/// A child process (posix_spawn); killed with SIGTERM and reaped when destroyed.
class ChildProcess {
 public:
  /// Starts argv[0] with the given arguments; stdout and stderr go to `log_path` if not empty.
  explicit ChildProcess(const std::vector<std::string>& argv, const std::string& log_path = "");
  ~ChildProcess();
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  bool running();
  /// Waits up to timeout_s for the exit; returns the exit status, or -1 on timeout
  /// (128 + signal if it was killed by a signal).
  int wait(double timeout_s);
  /// SIGTERM, then wait up to timeout_s; returns the exit status as wait().
  int stop(double timeout_s = 5.0);
  pid_t pid() const { return pid_; }

 private:
  pid_t pid_ = -1;
  int status_ = -1;
};

}  // namespace depowder::perception::testing
