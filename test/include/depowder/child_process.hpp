// Processes a multi-process test or benchmark starts, and the guard that it runs where udpm
// multicast cannot leave the machine (inside test/netns-run's private network namespace).
//
//   testutil::ChildProcess camera({exe, "--cell", cell}, "camera.log");
//   ...
//   EXPECT_EQ(camera.stop(), 0);  // SIGTERM, and a clean exit
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace depowder::testutil {

/// Runs `command` through the shell and waits for it: its exit status, or -1 if it did not exit
/// (a signal ended it).
inline int shellExitStatus(const std::string& command) {
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

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

/// A child process; stopped with SIGTERM (SIGKILL after 2 s) and reaped when destroyed, and
/// killed by the kernel if the test process dies first.
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

    std::vector<char*> args;
    for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    // fork + exec rather than posix_spawn, so the child can ask to be killed when the test dies
    // without stopping it (a crash, ctest's timeout): a cell left running would load the machine
    // for the tests after it. Between fork and exec only async-signal-safe calls. An exec that
    // fails writes its errno to a close-on-exec pipe, so a missing program still throws here.
    int report[2];
    if (pipe2(report, O_CLOEXEC) != 0) throw std::runtime_error("cannot start " + argv[0] + ": pipe failed");
    const pid_t parent = getpid();
    pid_ = fork();
    if (pid_ == 0) {
      prctl(PR_SET_PDEATHSIG, SIGKILL);
      if (getppid() != parent) _exit(127);  // the test died before the line above
      if (!log_path.empty()) {
        const int fd = open(log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        if (fd >= 0) {
          dup2(fd, 1);
          dup2(fd, 2);
          if (fd > 2) close(fd);
        }
      }
      execvpe(args[0], args.data(), envp.data());
      const int error = errno;
      (void)!write(report[1], &error, sizeof error);
      _exit(127);
    }
    close(report[1]);
    int error = 0;
    const bool exec_failed = pid_ > 0 && read(report[0], &error, sizeof error) == sizeof error;
    close(report[0]);
    if (pid_ < 0 || exec_failed) {
      if (pid_ > 0) waitpid(pid_, nullptr, 0);
      pid_ = -1;
      throw std::runtime_error("cannot start " + argv[0] +
                               (exec_failed ? std::string(": ") + std::strerror(error) : ""));
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
