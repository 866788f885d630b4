#include "supervisor.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sched.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <memory>
#include <thread>

namespace depowder::launch {

namespace {
using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }
}  // namespace

struct Supervisor::Proc {
  ProcessSpec spec;
  std::string path;  // resolved executable
  pid_t pid = 0;
  int out_fd = -1;
  std::int8_t state = process_status_t::STARTING;
  int restarts = 0;
  int in_a_row = 0;  // restarts since the process last ran stable_after_s
  int last_exit = 0;
  bool started_once = false;
  Clock::time_point started_at{};
  Clock::time_point next_start{};
  std::string partial;  // output not yet ended by a newline
  std::unique_ptr<std::ofstream> log;
};

Supervisor::Supervisor(HostSpec host, SupervisorOptions options)
    : host_(std::move(host)), options_(std::move(options)) {
  for (const ProcessSpec& spec : host_.processes) {
    Proc p;
    p.spec = spec;
    p.spec.command = expand(spec.command, options_.vars);
    for (auto& a : p.spec.args) a = expand(a, options_.vars);
    p.path = p.spec.command;
    if (p.path.find('/') == std::string::npos && access((options_.bin_dir + "/" + p.path).c_str(), X_OK) == 0)
      p.path = options_.bin_dir + "/" + p.path;
    if (!options_.run_dir.empty())
      p.log = std::make_unique<std::ofstream>(options_.run_dir + "/" + spec.name + ".log", std::ios::app);
    procs_.push_back(std::move(p));
  }
}

Supervisor::~Supervisor() { stopAll(); }

void Supervisor::emit(Proc& p, const std::string& line) {
  if (options_.echo) std::cout << "[" << p.spec.name << "] " << line << "\n" << std::flush;
  if (p.log) *p.log << line << "\n" << std::flush;
}

void Supervisor::start(Proc& p) {
  int fds[2];
  if (pipe2(fds, O_CLOEXEC) != 0) {
    emit(p, std::string("launcher: pipe failed: ") + std::strerror(errno));
    return;
  }
  const pid_t parent = getpid();
  const pid_t pid = fork();
  if (pid < 0) {
    emit(p, std::string("launcher: fork failed: ") + std::strerror(errno));
    close(fds[0]);
    close(fds[1]);
    return;
  }
  if (pid == 0) {  // child: own process group (so a stop reaches its children), output into the pipe
    setpgid(0, 0);
    // If the launcher dies without stopping it (SIGKILL, a crash), the process stops as on a
    // stop: none runs on unsupervised, nor beside the one a launcher started again would start.
    prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (getppid() != parent) _exit(0);  // the launcher died before the line above
    dup2(fds[1], STDOUT_FILENO);
    dup2(fds[1], STDERR_FILENO);
    if (!options_.lcm_url.empty()) setenv("LCM_DEFAULT_URL", options_.lcm_url.c_str(), 1);
    if (p.spec.realtime > 0) {  // inherited by the program's threads
      sched_param sp{};
      sp.sched_priority = p.spec.realtime;
      if (sched_setscheduler(0, SCHED_FIFO, &sp) != 0)
        std::fprintf(stderr, "launcher: realtime %d (SCHED_FIFO) not permitted (%s): normal scheduling\n",
                     p.spec.realtime, std::strerror(errno));
    }
    std::vector<char*> argv;
    argv.push_back(const_cast<char*>(p.path.c_str()));
    for (auto& a : p.spec.args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    execvp(argv[0], argv.data());
    std::fprintf(stderr, "launcher: cannot run '%s': %s\n", p.path.c_str(), std::strerror(errno));
    _exit(127);
  }
  setpgid(pid, pid);
  close(fds[1]);
  fcntl(fds[0], F_SETFL, O_NONBLOCK);
  p.pid = pid;
  p.out_fd = fds[0];
  p.state = process_status_t::RUNNING;
  p.started_at = Clock::now();
  p.started_once = true;
  std::string cmd = p.path;
  for (const auto& a : p.spec.args) cmd += " " + a;
  emit(p, "launcher: started pid " + std::to_string(pid) + ": " + cmd);
}

void Supervisor::pump(int timeout_ms) {
  std::vector<pollfd> fds;
  std::vector<Proc*> owners;
  for (Proc& p : procs_)
    if (p.out_fd >= 0) {
      fds.push_back({p.out_fd, POLLIN, 0});
      owners.push_back(&p);
    }
  if (fds.empty()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(timeout_ms));
    return;
  }
  if (poll(fds.data(), fds.size(), timeout_ms) <= 0) return;
  char buf[4096];
  for (std::size_t i = 0; i < fds.size(); ++i) {
    if (!(fds[i].revents & (POLLIN | POLLHUP | POLLERR))) continue;
    Proc& p = *owners[i];
    const ssize_t n = read(p.out_fd, buf, sizeof(buf));
    if (n > 0) {
      p.partial.append(buf, static_cast<std::size_t>(n));
      for (std::size_t nl; (nl = p.partial.find('\n')) != std::string::npos; p.partial.erase(0, nl + 1))
        emit(p, p.partial.substr(0, nl));
    } else if (n == 0 || (errno != EAGAIN && errno != EINTR)) {
      if (!p.partial.empty()) emit(p, p.partial);
      p.partial.clear();
      close(p.out_fd);
      p.out_fd = -1;
    }
  }
}

void Supervisor::reap() {
  int status = 0;
  for (pid_t pid; (pid = waitpid(-1, &status, WNOHANG)) > 0;) {
    for (Proc& p : procs_) {
      if (p.pid != pid) continue;
      p.pid = 0;
      p.last_exit = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
      const bool failed = p.last_exit != 0;
      if (p.state == process_status_t::STOPPED) break;
      const bool again = p.spec.restart == Restart::kAlways || (failed && p.spec.restart == Restart::kOnFailure);
      if (secondsSince(p.started_at) >= options_.stable_after_s) p.in_a_row = 0;  // it had started well
      if (again && p.in_a_row < p.spec.max_restarts && !p.spec.ends_run) {
        const double delay =
            std::min(options_.backoff_max_s, options_.backoff_initial_s * (1 << std::min(p.in_a_row, 16)));
        p.state = process_status_t::RESTARTING;
        p.next_start = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(delay));
        emit(p, "launcher: exited with " + std::to_string(p.last_exit) + "; restart " + std::to_string(p.restarts + 1) +
                    " in " + std::to_string(delay).substr(0, 4) + " s");
      } else {
        p.state = again ? process_status_t::FAILED : process_status_t::EXITED;
        emit(p, "launcher: exited with " + std::to_string(p.last_exit) +
                    (again ? " (gave up after " + std::to_string(p.in_a_row) + " restarts in a row)" : ""));
      }
      break;
    }
  }
}

void Supervisor::stopAll() {
  for (auto it = procs_.rbegin(); it != procs_.rend(); ++it)
    if (it->pid > 0) {
      it->state = process_status_t::STOPPED;
      kill(-it->pid, SIGTERM);
    }
  const auto start = Clock::now();
  auto anyAlive = [&] {
    for (const Proc& p : procs_)
      if (p.pid > 0) return true;
    return false;
  };
  while (anyAlive() && secondsSince(start) < options_.stop_timeout_s) {
    pump(50);
    reap();
  }
  for (Proc& p : procs_)
    if (p.pid > 0) {
      emit(p, "launcher: did not stop on SIGTERM; SIGKILL");
      kill(-p.pid, SIGKILL);
      waitpid(p.pid, nullptr, 0);
      p.pid = 0;
    }
  for (Proc& p : procs_) {
    pump(0);
    if (p.out_fd >= 0) close(p.out_fd), p.out_fd = -1;
    p.state = process_status_t::STOPPED;
  }
}

int Supervisor::run(const std::function<bool()>& stop, const std::function<void()>& tick) {
  std::size_t next = 0;  // next process to start for the first time
  auto next_time = Clock::now();
  int code = 0;
  while (!stop()) {
    if (next < procs_.size() && Clock::now() >= next_time) {
      start(procs_[next]);
      next_time = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                     std::chrono::duration<double>(procs_[next].spec.start_delay_s));
      ++next;
    }
    pump(100);
    reap();
    bool finished = false;
    for (Proc& p : procs_) {
      if (p.state == process_status_t::RESTARTING && Clock::now() >= p.next_start) {
        ++p.restarts;
        ++p.in_a_row;
        start(p);
      }
      if (p.spec.ends_run && p.started_once && p.pid == 0 &&
          (p.state == process_status_t::EXITED || p.state == process_status_t::FAILED)) {
        code = p.last_exit;
        finished = true;
      }
    }
    tick();
    if (finished) break;
  }
  stopAll();
  tick();
  return code;
}

launcher_status_t Supervisor::status() const {
  launcher_status_t s{};
  s.host = host_.name;
  for (const Proc& p : procs_) {
    process_status_t ps{};
    ps.name = p.spec.name;
    ps.command = p.path;
    ps.pid = p.pid;
    ps.state = p.state;
    ps.restarts = p.restarts;
    ps.last_exit_code = p.last_exit;
    ps.uptime_s = p.pid > 0 ? secondsSince(p.started_at) : 0.0;
    s.processes.push_back(ps);
  }
  s.num_processes = static_cast<std::int32_t>(s.processes.size());
  return s;
}

}  // namespace depowder::launch
