// depowder-status: a live table of every process's heartbeat (state, counters, CPU, memory).
#include <chrono>
#include <cstdio>
#include <iostream>
#include <map>

#include "depowder/heartbeat_t.hpp"
#include "depowder/node/bus.hpp"
#include "depowder/node/convert.hpp"
#include "depowder/node/shutdown.hpp"

namespace {

const char* stateName(int s) {
  static const char* names[] = {"starting", "running", "degraded", "stopping", "failed"};
  return s >= 0 && s <= 4 ? names[s] : "?";
}

int usage(const char* error = nullptr) {
  if (error) std::cerr << "depowder-status: " << error << "\n";
  std::cerr << "usage: depowder-status [--wait-for PROCESS] [--timeout S] [--once] [--url URL] [--prefix P]\n"
               "  Prints one line per process heard on HEARTBEAT, refreshed every second.\n"
               "  --wait-for P  exit 0 as soon as a heartbeat from process P arrives (1 on timeout)\n"
               "  --once        print the table once after --timeout seconds (default 2) and exit\n";
  return error ? 2 : 0;
}

}  // namespace

int main(int argc, char** argv) {
  std::string url, prefix, wait_for;
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
    depowder::node::Bus bus(url, prefix);
    std::map<std::string, depowder::heartbeat_t> last;  // by "process@host:pid"
    bool seen = false;
    bus.subscribe<depowder::heartbeat_t>("HEARTBEAT", [&](const depowder::heartbeat_t& h, const std::string&) {
      last[h.process + "@" + h.host + ":" + std::to_string(h.pid)] = h;
      if (h.process == wait_for) seen = true;
    });
    auto print = [&] {
      const std::int64_t now = depowder::node::nowUtime();
      std::printf("%-34s %-9s %7s %9s %9s %7s %8s %6s %8s  %s\n", "process@host:pid", "state", "age_s", "received",
                  "published", "decode", "dropped", "cpu%", "rss_MB", "reason");
      for (const auto& [key, h] : last)
        std::printf("%-34s %-9s %7.1f %9lld %9lld %7lld %8lld %6.1f %8.1f  %s\n", key.c_str(), stateName(h.state),
                    (now - h.utime) * 1e-6, static_cast<long long>(h.received), static_cast<long long>(h.published),
                    static_cast<long long>(h.decode_errors), static_cast<long long>(h.dropped), h.cpu_percent,
                    h.peak_rss_kb / 1024.0, h.state_reason.c_str());
      std::fflush(stdout);
    };
    const auto start = std::chrono::steady_clock::now();
    auto last_print = start;
    while (!depowder::node::shutdownRequested()) {
      bus.spinOnce(50);
      if (!wait_for.empty() && seen) {
        std::cout << "heard " << wait_for << "\n";
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
