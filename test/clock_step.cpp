// A host's system clock stepped, for the tests (NTP or an operator stepping it): preloaded into a
// process (LD_PRELOAD=.../libdepowder_clock_step.so), it adds to the system clock (clock_gettime
// of CLOCK_REALTIME, gettimeofday, time) the offset in seconds written in the file named by
// DEPOWDER_CLOCK_STEP_FILE, e.g. "-3600", read again every 10 ms. The steady clock, and every
// sleep and wait on it, is left alone, as such a step leaves it. A step moves the kernel's stamps
// of received packets as well, which no library can: a socket's SO_TIMESTAMP is therefore not
// turned on (the call says it is), and LCM, finding no stamp on a packet, stamps it with the system
// clock. Without this lcm-logger stamped a packet with the kernel's clock whenever LCM took a fresh
// receive buffer, and a log of the step came out with both clocks mixed.
//
// Not libfaketime: its FAKETIME_DONT_FAKE_MONOTONIC, which leaves the steady clock alone, makes
// clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME) return at once in 0.9.10 (Debian 12's), so the
// driver's slave loop spun (wolfcw/libfaketime issue 426).
#include <dlfcn.h>
#include <fcntl.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <atomic>
#include <cstdint>
#include <cstdlib>
#include <ctime>

namespace {

using ClockGettime = int (*)(clockid_t, timespec*);
using SetSockOpt = int (*)(int, int, int, const void*, socklen_t);

ClockGettime realClockGettime() {
  static const auto real = reinterpret_cast<ClockGettime>(dlsym(RTLD_NEXT, "clock_gettime"));
  return real;
}

std::int64_t nanoseconds(const timespec& t) { return std::int64_t{t.tv_sec} * 1000000000 + t.tv_nsec; }

std::atomic<std::int64_t> offset_ns{0};
std::atomic<std::int64_t> read_at_ns{-1};

/// The offset, from the file at most 10 ms old. With system calls only (no malloc): a clock is
/// read anywhere, a signal handler included.
std::int64_t offsetNs() {
  timespec now{};
  realClockGettime()(CLOCK_MONOTONIC, &now);
  const std::int64_t t = nanoseconds(now), last = read_at_ns.load(std::memory_order_relaxed);
  if (last >= 0 && t - last < 10000000) return offset_ns.load(std::memory_order_relaxed);
  read_at_ns.store(t, std::memory_order_relaxed);
  const char* path = std::getenv("DEPOWDER_CLOCK_STEP_FILE");
  const int fd = path ? open(path, O_RDONLY | O_CLOEXEC) : -1;
  if (fd < 0) return offset_ns.load(std::memory_order_relaxed);
  char buf[64] = {};
  const ssize_t n = read(fd, buf, sizeof buf - 1);
  close(fd);
  char* end = nullptr;
  const double seconds = n > 0 ? std::strtod(buf, &end) : 0;
  if (n > 0 && end != buf) offset_ns.store(static_cast<std::int64_t>(seconds * 1e9), std::memory_order_relaxed);
  return offset_ns.load(std::memory_order_relaxed);
}

}  // namespace

extern "C" {

int clock_gettime(clockid_t clock, timespec* ts) noexcept {
  const int r = realClockGettime()(clock, ts);
  if (r == 0 && (clock == CLOCK_REALTIME || clock == CLOCK_REALTIME_COARSE)) {
    const std::int64_t t = nanoseconds(*ts) + offsetNs();
    ts->tv_sec = static_cast<time_t>(t / 1000000000);
    ts->tv_nsec = static_cast<long>(t % 1000000000);
  }
  return r;
}

int gettimeofday(timeval* tv, void*) noexcept {
  timespec ts{};
  const int r = clock_gettime(CLOCK_REALTIME, &ts);
  tv->tv_sec = ts.tv_sec;
  tv->tv_usec = static_cast<suseconds_t>(ts.tv_nsec / 1000);
  return r;
}

int setsockopt(int fd, int level, int name, const void* value, socklen_t length) noexcept {
  if (level == SOL_SOCKET && (name == SO_TIMESTAMP || name == SO_TIMESTAMPNS)) return 0;
  static const auto real = reinterpret_cast<SetSockOpt>(dlsym(RTLD_NEXT, "setsockopt"));
  return real(fd, level, name, value, length);
}

time_t time(time_t* out) noexcept {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  if (out) *out = ts.tv_sec;
  return ts.tv_sec;
}

}  // extern "C"
