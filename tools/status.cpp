// depowder-status: a live table of every process's heartbeat (state, counters, CPU, memory, and
// how far its host's clock is from this one's).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <map>
#include <optional>

#include "depowder/heartbeat_t.hpp"
#include "depowder/node/bus.hpp"
#include "depowder/node/cell.hpp"
#include "depowder/node/convert.hpp"
#include "depowder/node/heartbeat.hpp"
#include "depowder/node/shutdown.hpp"

namespace {

// A heartbeat and when it arrived (this host's clock).
struct Heard {
  depowder::heartbeat_t h;
  std::int64_t arrived_utime = 0;
  // The sender's clock less this host's, ms: its utime is stamped as it is sent, so this is the
  // clocks' difference plus the transit time (well under a millisecond on a LAN).
  double clockMs() const { return (h.utime - arrived_utime) * 1e-3; }
};

// Beyond this the hosts' clocks disagree enough to matter: the driver measures a plan's age
// from its camera frame's utime (robot.plan_max_age, plan_max_lead).
constexpr double kClockWarnMs = 100;

// A process heard within this many seconds is running (heartbeats come at 2 Hz or more).
constexpr double kLiveS = 3;
// The processes a cell runs one of each.
const char* const kOnePerCell[] = {"depowder-sim",      "depowder-camera",  "depowder-tracker",
                                   "depowder-progress", "depowder-planner", "depowder-driver"};

const char* stateName(int s) {
  static const char* names[] = {"starting", "running", "degraded", "stopping", "failed"};
  return s >= 0 && s <= 4 ? names[s] : "?";
}

int usage(const char* error = nullptr) {
  if (error) std::cerr << "depowder-status: " << error << "\n";
  std::cerr
      << "usage: depowder-status [--wait-for PROCESS] [--timeout S] [--once] [--cell FILE] [--url URL] [--prefix P]\n"
         "  Prints one line per process heard on HEARTBEAT, refreshed every second: age of its last\n"
         "  heartbeat, counters, CPU, memory, and clock_ms, its host's clock less this host's (a\n"
         "  difference beyond 100 ms is flagged: plan ages in the driver need agreeing clocks). Says\n"
         "  so when the processes' cell files differ in the sections they share (box, cameras, parts),\n"
         "  and when two of one cell process run (a second cell on the same LAN and prefix).\n"
         "  --wait-for P  exit 0 as soon as a heartbeat from process P arrives (1 on timeout)\n"
         "  --once        print the table once after --timeout seconds (default 2) and exit\n"
         "  The bus is the cell file's (lcm section; default: the default cell) unless --url / --prefix.\n";
  return error ? 2 : 0;
}

}  // namespace

int main(int argc, char** argv) {
  std::string cell, wait_for;
  std::optional<std::string> url, prefix;
  double timeout = -1;
  bool once = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") return usage();
    if (a == "--once") {
      once = true;
      continue;
    }
    if (i + 1 >= argc) return usage(("missing value after " + a).c_str());
    if (a == "--wait-for")
      wait_for = argv[++i];
    else if (a == "--timeout")
      timeout = std::atof(argv[++i]);
    else if (a == "--cell")
      cell = argv[++i];
    else if (a == "--url")
      url = argv[++i];
    else if (a == "--prefix")
      prefix = argv[++i];
    else
      return usage(("unknown option " + a).c_str());
  }
  if (once && timeout < 0) timeout = 2;
  try {
    depowder::node::installShutdownHandlers();
    const depowder::node::LcmConfig lcm = depowder::node::toolBus("depowder-status", cell, url, prefix);
    depowder::node::Bus bus(lcm.url, lcm.prefix);
    std::map<std::string, Heard> last;  // by "process@host:pid"
    const Heard* seen = nullptr;
    bus.subscribe<depowder::heartbeat_t>("HEARTBEAT", [&](const depowder::heartbeat_t& h, const std::string&) {
      Heard& heard = last[h.process + "@" + h.host + ":" + std::to_string(h.pid)];
      heard = {h, depowder::node::nowUtime()};
      if (h.process == wait_for) seen = &heard;
    });
    auto print = [&] {
      const std::int64_t now = depowder::node::nowUtime();
      std::printf("%-34s %-9s %7s %9s %9s %7s %8s %6s %8s %9s  %s\n", "process@host:pid", "state", "age_s", "received",
                  "published", "decode", "dropped", "cpu%", "rss_MB", "clock_ms", "reason");
      std::string apart;
      for (const auto& [key, heard] : last) {
        const depowder::heartbeat_t& h = heard.h;
        std::printf("%-34s %-9s %7.1f %9lld %9lld %7lld %8lld %6.1f %8.1f %+9.1f  %s\n", key.c_str(),
                    stateName(h.state), (now - heard.arrived_utime) * 1e-6, static_cast<long long>(h.received),
                    static_cast<long long>(h.published), static_cast<long long>(h.decode_errors),
                    static_cast<long long>(h.dropped), h.cpu_percent, h.peak_rss_kb / 1024.0, heard.clockMs(),
                    h.state_reason.c_str());
        if (std::abs(heard.clockMs()) > kClockWarnMs && apart.find(h.host) == std::string::npos)
          apart += (apart.empty() ? "" : ", ") + h.host;
      }
      // Of the processes running now (heard within kLiveS, not stopping): the shared sections of
      // their cell files (node::cellModelId), one value expected; one of each cell process.
      std::map<double, std::string> models;      // cell_model -> the processes that read it
      std::map<std::string, std::string> kinds;  // cell process -> each one running
      for (const auto& [key, heard] : last) {
        if ((now - heard.arrived_utime) * 1e-6 > kLiveS || heard.h.state == depowder::heartbeat_t::STOPPING) continue;
        if (const double model = depowder::node::heartbeatStat(heard.h, "cell_model"); !std::isnan(model)) {
          std::string& who = models[model];
          who += (who.empty() ? "" : ", ") + key;
        }
        for (const char* kind : kOnePerCell)
          if (heard.h.process == kind) kinds[kind] += (kinds[kind].empty() ? "" : ", ") + key;
      }
      for (const auto& [kind, who] : kinds)
        if (who.find(", ") != std::string::npos)
          std::printf("more than one %s: %s; one cell runs one (another cell on this LAN needs its own lcm.prefix)\n",
                      kind.c_str(), who.c_str());
      if (models.size() > 1) {
        std::printf("cell files differ (box, cameras or parts; cell_model):");
        for (const auto& [model, who] : models) std::printf(" %.0f in %s;", model, who.c_str());
        std::printf(" every host needs the same\n");
      }
      if (!apart.empty())
        std::printf(
            "clocks: %s differ from this host's by more than %.0f ms; synchronise them (chrony, PTP): the "
            "driver judges a plan's age by its camera frame's time\n",
            apart.c_str(), kClockWarnMs);
      std::fflush(stdout);
    };
    const auto start = std::chrono::steady_clock::now();
    auto last_print = start;
    while (!depowder::node::shutdownRequested()) {
      bus.spinOnce(50);
      if (!wait_for.empty() && seen) {
        std::printf("heard %s on %s (its clock %+.1f ms from this host's)\n", wait_for.c_str(), seen->h.host.c_str(),
                    seen->clockMs());
        return 0;
      }
      const auto now = std::chrono::steady_clock::now();
      const double elapsed = std::chrono::duration<double>(now - start).count();
      if (timeout >= 0 && elapsed >= timeout) {
        if (once) print();
        if (!wait_for.empty())
          std::cerr << "depowder-status: no heartbeat from " << wait_for << " in " << timeout << " s\n";
        return wait_for.empty() ? 0 : 1;
      }
      if (!once && wait_for.empty() && now - last_print >= std::chrono::seconds(1)) {
        last_print = now;
        std::printf("\n");
        print();
      }
    }
  } catch (const std::exception& e) {
    std::cerr << "depowder-status: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
