// depowder-launch's supervisor: restarts with back-off, and gives up only on restarts in a row.
#include <gtest/gtest.h>

#include <chrono>

#include "supervisor.hpp"

namespace depowder::launch {
namespace {

ProcessSpec shell(const std::string& name, const std::string& script, int max_restarts) {
  ProcessSpec p;
  p.name = name;
  p.command = "/bin/sh";
  p.args = {"-c", script};
  p.max_restarts = max_restarts;
  return p;
}

// `quick` fails at once, every time: FAILED after max_restarts. `steady` fails too, but each
// run lasts longer than stable_after_s: it had started well, so it is restarted for good, each
// time after the first back-off again.
TEST(Supervisor, GivesUpOnlyOnRestartsInARow) {
  HostSpec host;
  host.name = "test";
  host.processes = {shell("quick", "exit 3", 2), shell("steady", "sleep 1.2; exit 4", 2)};
  SupervisorOptions options;
  options.echo = false;
  options.backoff_initial_s = 0.05;
  options.backoff_max_s = 0.1;
  options.stable_after_s = 1.0;
  Supervisor supervisor(host, options);
  launcher_status_t last;
  const auto start = std::chrono::steady_clock::now();
  supervisor.run([&] { return std::chrono::steady_clock::now() - start > std::chrono::seconds(6); },
                 [&] {
                   if (supervisor.status().processes[1].state != process_status_t::STOPPED) last = supervisor.status();
                 });
  ASSERT_EQ(last.processes.size(), 2u);
  const process_status_t& quick = last.processes[0];
  const process_status_t& steady = last.processes[1];
  EXPECT_EQ(quick.state, +process_status_t::FAILED);
  EXPECT_EQ(quick.restarts, 2);
  EXPECT_EQ(quick.last_exit_code, 3);
  // 6 s of 1.2 s runs and 0.05 s back-offs: 4 restarts, 3 on a loaded machine; never given up.
  EXPECT_GE(steady.restarts, 3);
  EXPECT_NE(steady.state, +process_status_t::FAILED);
}

}  // namespace
}  // namespace depowder::launch
