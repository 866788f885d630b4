// SIGINT / SIGTERM set a flag that every main loop polls, for a clean shutdown.
#pragma once

namespace depowder::node {

/// Installs the handlers (idempotent).
void installShutdownHandlers();
/// True once SIGINT or SIGTERM has arrived.
bool shutdownRequested();

}  // namespace depowder::node
