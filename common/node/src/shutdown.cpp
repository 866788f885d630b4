#include "depowder/node/shutdown.hpp"

#include <csignal>

namespace depowder::node {
namespace {
volatile std::sig_atomic_t g_stop = 0;
extern "C" void onSignal(int) { g_stop = 1; }
}  // namespace

void installShutdownHandlers() {
  struct sigaction sa {};
  sa.sa_handler = onSignal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
}

bool shutdownRequested() { return g_stop != 0; }

}  // namespace depowder::node
