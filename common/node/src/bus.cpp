#include "depowder/node/bus.hpp"

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <exception>
#include <utility>

#include "depowder/node/shutdown.hpp"
#include "depowder/robot_state_v1_t.hpp"

namespace depowder::node {

namespace {
/// Why a message did not decode, when its fingerprint is a type's as it was before a field was
/// added (lcmtypes/legacy): a log recorded then, played again.
std::string legacyHint(const void* data, std::uint32_t size) {
  if (size < 8) return "";
  std::uint64_t hash = 0;
  for (int i = 0; i < 8; ++i) hash = hash << 8 | static_cast<const std::uint8_t*>(data)[i];
  if (hash == static_cast<std::uint64_t>(robot_state_v1_t::getHash()))
    return ": robot_state_t as recorded before it gained `measured` (commit eeee3d1); "
           "`depowder-logmend OLD.lcmlog NEW.lcmlog` writes it in the present type";
  return "";
}
}  // namespace

struct Bus::Subscription {
  Bus* bus;
  RawHandler handler;
  void handle(const lcm::ReceiveBuffer* rbuf, const std::string& ch) {
    try {
      if (handler(rbuf->data, static_cast<int>(rbuf->data_size), ch)) {
        ++bus->counters_.received;
      } else {
        ++bus->counters_.decode_errors;
        const std::string legacy = legacyHint(rbuf->data, rbuf->data_size);
        bus->keepError("could not decode a " + std::to_string(rbuf->data_size) + "-byte message on " + ch +
                       (legacy.empty() ? " (wrong type or corrupt)" : legacy));
      }
    } catch (const std::exception& e) {
      ++bus->counters_.handler_errors;
      bus->keepError("handler for " + ch + " failed: " + e.what());
    } catch (...) {
      ++bus->counters_.handler_errors;
      bus->keepError("handler for " + ch + " failed with an unknown exception");
    }
  }
};

namespace {
std::string effectiveUrl(const std::string& url) {
  if (!url.empty()) return url;
  const char* env = std::getenv("LCM_DEFAULT_URL");
  return env ? env : "";
}
}  // namespace

Bus::Bus(const std::string& url, std::string prefix) : prefix_(std::move(prefix)), lcm_(effectiveUrl(url)) {
  if (!lcm_.good()) {
    const std::string shown = effectiveUrl(url).empty() ? "LCM's default udpm URL" : effectiveUrl(url);
    throw BusError("LCM could not start on " + shown +
                   ". With udpm this usually means the host has no multicast route (no network, or a fresh network "
                   "namespace). Fix: `ip link set lo multicast on; ip route add 224.0.0.0/4 dev lo` (as root), or run "
                   "with LCM_DEFAULT_URL=memq:// for a single process.");
  }
}

Bus::~Bus() = default;

void Bus::subscribeRaw(const std::string& pattern, RawHandler handler) {
  auto sub = std::make_unique<Subscription>(Subscription{this, std::move(handler)});
  lcm_.subscribe(channel(pattern), &Subscription::handle, sub.get());
  subscriptions_.push_back(std::move(sub));
}

void Bus::publishRaw(const std::string& name, const void* data, int size) {
  if (lcm_.publish(channel(name), data, static_cast<unsigned int>(size)) == 0) {
    ++counters_.published;
  } else {
    keepError("publish on " + channel(name) + " failed");
  }
}

int Bus::spinOnce(int timeout_ms) {
  const auto before = counters_.received + counters_.decode_errors + counters_.handler_errors;
  errno = 0;
  const int rc = lcm_.handleTimeout(timeout_ms);
  if (rc < 0 && (errno == EINTR || shutdownRequested())) return 0;  // SIGTERM or SIGINT interrupted the wait
  if (rc < 0) throw BusError("LCM handle failed (the LCM socket reported an error)");
  return static_cast<int>(counters_.received + counters_.decode_errors + counters_.handler_errors - before);
}

int Bus::drain(int max_messages) {
  int handled = 0;
  while (handled < max_messages && !shutdownRequested()) {
    errno = 0;
    const int rc = lcm_.handleTimeout(0);
    if (rc < 0 && errno == EINTR) break;  // a signal: the caller's loop checks shutdownRequested()
    if (rc < 0) throw BusError("LCM handle failed (the LCM socket reported an error)");
    if (rc == 0) break;
    ++handled;
  }
  return handled;
}

bool Bus::spinUntil(const std::function<bool()>& done, double seconds, int step_ms) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (!done() && std::chrono::steady_clock::now() < end) spinOnce(step_ms);
  return done();
}

Bus::Counters Bus::counters() const { return counters_; }

void Bus::keepError(std::string what) {
  std::lock_guard<std::mutex> lock(errors_mutex_);
  if (errors_.size() < 100) errors_.push_back(std::move(what));
}

std::vector<std::string> Bus::takeErrors() {
  std::lock_guard<std::mutex> lock(errors_mutex_);
  return std::exchange(errors_, {});
}

}  // namespace depowder::node
