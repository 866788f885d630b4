// A deployment: which processes run on which host, with what arguments, and how
// they are restarted (config/deploy/*.yaml).
#pragma once

#include <map>
#include <string>
#include <vector>

namespace depowder::launch {

enum class Restart { kNever, kOnFailure, kAlways };

struct ProcessSpec {
  std::string name;               ///< short name, prefixes its output lines
  std::string command;            ///< executable; without '/', looked up beside depowder-launch, then in PATH
  std::vector<std::string> args;  ///< ${VAR} expands from --set VAR=value and the built-ins
  Restart restart = Restart::kOnFailure;
  int max_restarts = 10;       ///< in a row (each run shorter than stable_after_s), then FAILED
  double start_delay_s = 0.0;  ///< wait before starting the next process
  bool ends_run = false;       ///< when it exits, the launcher stops all and exits with its code
  /// SCHED_FIFO priority (1-99) the process starts with, so other work on the machine cannot
  /// delay it; 0 = normal scheduling. Without the privilege it runs normally, with a warning.
  int realtime = 0;
};

struct HostSpec {
  std::string name;
  std::vector<ProcessSpec> processes;  ///< started in this order, stopped in reverse
};

struct Deployment {
  std::string file;
  std::string lcm_url;                           ///< exported as LCM_DEFAULT_URL to every process ("" = inherit)
  std::map<std::string, std::string> variables;  ///< defaults for ${VAR}
  std::vector<HostSpec> hosts;
};

/// Reads and validates a deployment file; throws node::ConfigError naming file and key.
Deployment loadDeployment(const std::string& path);

/// Expands ${VAR} in `text` from `vars`; throws std::invalid_argument naming an unknown variable.
std::string expand(const std::string& text, const std::map<std::string, std::string>& vars);

}  // namespace depowder::launch
