// Processes a multi-process test or benchmark starts, and the guard that it runs where udpm
// multicast cannot leave the machine (inside test/netns-run's private network namespace).
//
//   testutil::ChildProcess camera({exe, "--cell", cell}, "camera.log");
//   ...
//   EXPECT_EQ(camera.stop(), 0);  // SIGTERM, and a clean exit
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace depowder::testutil {

/// True when this process sees no network interface but loopback (as inside test/netns-run),
/// so udpm multicast cannot reach a real interface. `why` lists the interfaces otherwise.
inline bool inPrivateNetwork(std::string* why = nullptr) {
  // /proc/self/net/dev lists the interfaces of this process's network namespace (/sys/class/net
  // would show the namespace sysfs was mounted in).
  std::ifstream dev("/proc/self/net/dev");
  if (!dev) {
    if (why) *why = "cannot read /proc/self/net/dev";
    return false;
  }
  std::vector<std::string> others;
  std::string line;
  while (std::getline(dev, line)) {
    const auto colon = line.find(':');
    if (colon == std::string::npos) continue;  // the two header lines
    const auto start = line.find_first_not_of(' ');
    const std::string name = line.substr(start, colon - start);
    if (name != "lo") others.push_back(name);
  }
  if (!others.empty() && why) {
    *why = "interfaces besides lo:";
    for (const auto& o : others) *why += " " + o;
  }
  return others.empty();
}

/// Why a program that talks udpm between processes must not run here: empty inside a private
/// network namespace, otherwise the refusal, naming the interfaces seen. The one wording of the
/// benchmarks' refusal, DriverProcess's and the netns gtest programs' skip.
inline std::string multicastRefusal() {
  std::string why;
  if (inPrivateNetwork(&why)) return {};
  return "refusing to send multicast here (" + why + "); run it through test/netns-run";
}

/// For a benchmark that talks udpm between processes: true inside a private network namespace;
/// otherwise false, after telling stderr why `program` refuses.
inline bool privateNetworkOrRefuse(const char* program) {
  const std::string refusal = multicastRefusal();
  if (!refusal.empty()) std::fprintf(stderr, "%s: %s\n", program, refusal.c_str());
  return refusal.empty();
}

/// A child process (posix_spawn); stopped with SIGTERM (SIGKILL after 2 s) and reaped when
/// destroyed.
class ChildProcess {
 public:
  /// Starts the executable argv[0] (a path, or a name looked up in PATH) with the rest as its
  /// arguments; its stdout and stderr go to `log_path` if not empty. `env` changes this
  /// process's environment for the child: "NAME=VALUE" sets NAME, "NAME" removes it.
  explicit ChildProcess(const std::vector<std::string>& argv, const std::string& log_path = "",
                        const std::vector<std::string>& env = {}) {
    auto nameOf = [](const std::string& entry) { return entry.substr(0, entry.find('=')); };
    std::vector<std::string> environment;
    for (char** e = environ; *e != nullptr; ++e) {
      bool changed = false;
      for (const std::string& c : env) changed = changed || nameOf(c) == nameOf(*e);
      if (!changed) environment.emplace_back(*e);
    }
    for (const std::string& c : env)
      if (c.find('=') != std::string::npos) environment.push_back(c);
    std::vector<char*> envp;
    for (std::string& e : environment) envp.push_back(e.data());
    envp.push_back(nullptr);

    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    if (!log_path.empty()) {
      posix_spawn_file_actions_addopen(&actions, 1, log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      posix_spawn_file_actions_adddup2(&actions, 1, 2);
    }
    std::vector<char*> args;
    for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    const int rc = posix_spawnp(&pid_, args[0], &actions, nullptr, args.data(), envp.data());
    posix_spawn_file_actions_destroy(&actions);
    if (rc != 0) {
      pid_ = -1;
      throw std::runtime_error("cannot start " + argv[0]);
    }
  }
  ~ChildProcess() {
    if (pid_ > 0 && status_ < 0) stop(2.0);
    if (pid_ > 0 && status_ < 0) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
  }
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  bool running() { return wait(0) < 0; }
  /// Waits up to timeout_s for the exit; returns the exit status, 128 + the signal if a signal
  /// ended it, or -1 on timeout.
  int wait(double timeout_s) {
    if (status_ >= 0) return status_;
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (true) {
      int st = 0;
      if (waitpid(pid_, &st, WNOHANG) == pid_) {
        status_ = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
        return status_;
      }
      if (std::chrono::steady_clock::now() >= end) return -1;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  }
  /// SIGTERM, then wait up to timeout_s; returns the exit status as wait().
  int stop(double timeout_s = 5.0) {
    if (status_ >= 0) return status_;
    kill(pid_, SIGTERM);
    return wait(timeout_s);
  }
  pid_t pid() const { return pid_; }

 private:
  pid_t pid_ = -1;
  int status_ = -1;
};

}  // namespace depowder::testutil
