// depowder-bcap-emulator: the b-CAP controller emulator on its own (no simulator), for
// testing depowder-driver and for fuzzing. Prints the arm state once a second.
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>

#include "depowder/sim/bcap_emulator.hpp"

namespace {
volatile std::sig_atomic_t g_stop = 0;
void onSignal(int) { g_stop = 1; }

void usage() {
  std::printf(
      "usage: depowder-bcap-emulator [--bind ADDR] [--port N] [--quiet]\n"
      "  --bind ADDR  IPv4 address to listen on (default 127.0.0.1)\n"
      "  --port N     TCP port (default 5007; 0 = any free port, printed at start)\n"
      "  --quiet      do not print the arm state every second\n");
}
}  // namespace

int main(int argc, char** argv) {
  depowder::sim::BcapEmulatorConfig cfg;
  bool quiet = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--bind" && i + 1 < argc) {
      cfg.bind_address = argv[++i];
    } else if (a == "--port" && i + 1 < argc) {
      char* end = nullptr;
      const long p = std::strtol(argv[++i], &end, 10);
      if (*end != '\0' || p < 0 || p > 65535) {
        std::fprintf(stderr, "depowder-bcap-emulator: --port must be 0..65535, got '%s'\n", argv[i]);
        return 2;
      }
      cfg.port = static_cast<int>(p);
    } else if (a == "--quiet") {
      quiet = true;
    } else if (a == "--help" || a == "-h") {
      usage();
      return 0;
    } else {
      std::fprintf(stderr, "depowder-bcap-emulator: unknown argument '%s'\n", a.c_str());
      usage();
      return 2;
    }
  }
  std::signal(SIGINT, onSignal);
  std::signal(SIGTERM, onSignal);

  depowder::sim::BcapEmulator emu(cfg);
  std::string error;
  if (!emu.start(&error)) {
    std::fprintf(stderr, "depowder-bcap-emulator: %s\n", error.c_str());
    return 1;
  }
  std::printf("depowder-bcap-emulator: listening on %s:%d\n", cfg.bind_address.c_str(), emu.port());
  std::fflush(stdout);
  int ticks = 0;
  while (!g_stop) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    if (quiet || ++ticks % 10 != 0) continue;
    const auto j = emu.joints();
    const auto t = emu.tool();
    const auto s = emu.stats();
    std::printf(
        "q [%.3f %.3f %.3f %.3f %.3f %.3f] rad  motor %d slave %d halted %d  vacuum %d air %d  moves %lld  "
        "packets %lld malformed %lld errors %lld\n",
        j.q[0], j.q[1], j.q[2], j.q[3], j.q[4], j.q[5], j.motor_on, j.slave_mode, emu.halted(), t.vacuum, t.air,
        static_cast<long long>(j.slave_moves), static_cast<long long>(s.packets), static_cast<long long>(s.malformed),
        static_cast<long long>(s.error_replies));
    std::fflush(stdout);
  }
  emu.stop();
  return 0;
}
