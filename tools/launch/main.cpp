// depowder-launch: runs one host's share of a deployment (config/deploy/*.yaml).
#include <linux/limits.h>
#include <sys/stat.h>
#include <unistd.h>

#include <ctime>
#include <iostream>

#include "deployment.hpp"
#include "depowder/heartbeat_t.hpp"
#include "depowder/node/bus.hpp"
#include "depowder/node/cell.hpp"
#include "depowder/node/convert.hpp"
#include "depowder/node/heartbeat.hpp"
#include "depowder/node/shutdown.hpp"
#include "supervisor.hpp"

using namespace depowder;

namespace {

int usage(const std::string& error = "") {
  if (!error.empty()) std::cerr << "depowder-launch: " << error << "\n";
  std::cerr << "usage: depowder-launch DEPLOYMENT.yaml [--host NAME] [--set VAR=VALUE]... [--run-dir DIR]\n"
               "                       [--quiet] [--no-status]\n"
               "  Starts the processes of one host of the deployment in order, prefixes their output\n"
               "  with [name] and keeps it in RUN_DIR/<name>.log, restarts a crashed process with\n"
               "  back-off, and stops them all on SIGINT/SIGTERM. Publishes LAUNCHER (launcher_status_t)\n"
               "  at 1 Hz and a HEARTBEAT. --host defaults to the only host, or the one named like this machine.\n"
               "  Variables for ${VAR} in commands and args: CELL (default cell), RUN_DIR, BIN_DIR, HOST,\n"
               "  SOURCE_DIR, plus the deployment's `variables:` and --set.\n";
  return error.empty() ? 0 : 2;
}

std::string selfDir() {
  char buf[PATH_MAX] = {0};
  const ssize_t n = readlink("/proc/self/exe", buf, sizeof(buf) - 1);
  std::string p = n > 0 ? std::string(buf, static_cast<std::size_t>(n)) : ".";
  return p.substr(0, p.find_last_of('/'));
}

std::string defaultRunDir() {
  char stamp[32];
  const std::time_t t = std::time(nullptr);
  std::strftime(stamp, sizeof(stamp), "%Y%m%d-%H%M%S", std::localtime(&t));
  return std::string("runs/") + stamp;
}

}  // namespace

int main(int argc, char** argv) {
  std::string deployment_file, host_name, run_dir;
  std::map<std::string, std::string> sets;
  bool quiet = false, publish_status = true;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") return usage();
    if (a == "--quiet") {
      quiet = true;
    } else if (a == "--no-status") {
      publish_status = false;
    } else if (a == "--host" || a == "--set" || a == "--run-dir") {
      if (i + 1 >= argc) return usage("missing value after " + a);
      const std::string v = argv[++i];
      if (a == "--host") host_name = v;
      if (a == "--run-dir") run_dir = v;
      if (a == "--set") {
        const auto eq = v.find('=');
        if (eq == std::string::npos || eq == 0) return usage("--set wants VAR=VALUE, got '" + v + "'");
        sets[v.substr(0, eq)] = v.substr(eq + 1);
      }
    } else if (a.rfind("--", 0) == 0 || !deployment_file.empty()) {
      return usage("unexpected argument '" + a + "'");
    } else {
      deployment_file = a;
    }
  }
  if (deployment_file.empty()) return usage("missing DEPLOYMENT.yaml");

  try {
    const launch::Deployment deployment = launch::loadDeployment(deployment_file);
    const launch::HostSpec* host = nullptr;
    const std::string machine = node::hostName();
    for (const auto& h : deployment.hosts)
      if (h.name == host_name || (host_name.empty() && (deployment.hosts.size() == 1 || h.name == machine))) host = &h;
    if (!host) {
      std::string names;
      for (const auto& h : deployment.hosts) names += " " + h.name;
      return usage("no host '" + (host_name.empty() ? machine : host_name) + "' in " + deployment_file +
                   " (hosts:" + names + "); pass --host");
    }
    if (run_dir.empty()) run_dir = defaultRunDir();
    if (system(("mkdir -p '" + run_dir + "'").c_str()) != 0) throw std::runtime_error("cannot create " + run_dir);

    launch::SupervisorOptions options;
    options.bin_dir = selfDir();
    options.run_dir = run_dir;
    options.lcm_url = deployment.lcm_url;
    options.echo = !quiet;
    options.vars = deployment.variables;
    options.vars["CELL"] = node::defaultCellPath();
    options.vars["RUN_DIR"] = run_dir;
    options.vars["BIN_DIR"] = options.bin_dir;
    options.vars["HOST"] = host->name;
    options.vars["SOURCE_DIR"] = DEPOWDER_SOURCE_DIR;
    for (const auto& [k, v] : deployment.variables) options.vars[k] = launch::expand(v, options.vars);
    for (const auto& [k, v] : sets) options.vars[k] = v;
    if (!deployment.lcm_url.empty()) setenv("LCM_DEFAULT_URL", deployment.lcm_url.c_str(), 1);

    node::installShutdownHandlers();
    std::unique_ptr<node::Bus> bus;
    std::unique_ptr<node::Heartbeat> heartbeat;
    if (publish_status) {
      bus = std::make_unique<node::Bus>("", "");
      heartbeat = std::make_unique<node::Heartbeat>(*bus, "depowder-launch");
      heartbeat->setState(heartbeat_t::RUNNING);
    }
    std::cout << "depowder-launch: host " << host->name << ", " << host->processes.size() << " processes, logs in "
              << run_dir << std::endl;
    launch::Supervisor supervisor(*host, options);
    std::int64_t last_status = 0;
    const int code = supervisor.run([] { return node::shutdownRequested(); },
                                    [&] {
                                      if (!bus) return;
                                      // Each second on the steady clock: a step of the system clock
                                      // neither silences nor floods the status.
                                      const std::int64_t now = node::steadyUtime();
                                      if (now - last_status < 1000000) return;
                                      last_status = now;
                                      launcher_status_t s = supervisor.status();
                                      s.utime = node::nowUtime();
                                      s.deployment = deployment_file;
                                      bus->publish("LAUNCHER", s);
                                      heartbeat->tick();
                                    });
    std::cout << "depowder-launch: stopped (exit " << code << ")" << std::endl;
    return code;
  } catch (const std::exception& e) {
    std::cerr << "depowder-launch: " << e.what() << "\n";
    return 2;
  }
}
