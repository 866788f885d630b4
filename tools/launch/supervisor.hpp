// Runs one host's processes: starts them in order, prefixes and keeps their output,
// restarts a crashed one with back-off, stops them all cleanly.
#pragma once

#include <functional>
#include <map>
#include <string>
#include <vector>

#include "deployment.hpp"
#include "depowder/launcher_status_t.hpp"

namespace depowder::launch {

struct SupervisorOptions {
  std::string bin_dir;                      ///< where depowder-* executables are looked up first
  std::string run_dir;                      ///< <name>.log per process ("" = no log files)
  std::string lcm_url;                      ///< LCM_DEFAULT_URL for the children ("" = inherit)
  std::map<std::string, std::string> vars;  ///< ${VAR} values
  bool echo = true;                         ///< copy output lines to our stdout
  double backoff_initial_s = 0.5;           ///< first restart delay, doubled each time
  double backoff_max_s = 8.0;
  /// A process that ran this long before it exited had started well: its back-off and its count
  /// towards max_restarts start over (only restarts in a row give up).
  double stable_after_s = 60.0;
  double stop_timeout_s = 5.0;  ///< SIGTERM, then SIGKILL after this long
};

class Supervisor {
 public:
  Supervisor(HostSpec host, SupervisorOptions options);
  ~Supervisor();

  /// Runs until `stop()` returns true or an ends_run process exits; then stops everything.
  /// `tick` is called about every 100 ms (publish status there). Returns the exit code:
  /// the ends_run process's, 0 after a requested stop, 1 if a process FAILED with ends_run.
  int run(const std::function<bool()>& stop, const std::function<void()>& tick);

  launcher_status_t status() const;

 private:
  struct Proc;
  void start(Proc& p);
  void pump(int timeout_ms);
  void reap();
  void stopAll();
  void emit(Proc& p, const std::string& line);

  HostSpec host_;
  SupervisorOptions options_;
  std::vector<Proc> procs_;
};

}  // namespace depowder::launch
