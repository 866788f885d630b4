// Priority inversion, made to happen on one CPU (SCHED_FIFO; skipped where not permitted): a
// low-priority thread holds the lock and needs 5 ms of CPU to let it go; a middle-priority thread
// spins for 100 ms; then a high-priority thread asks for the lock. With std::mutex it waits for
// the whole spin; with PiMutex the holder runs at the waiter's priority and it waits ~5 ms.
#include <gtest/gtest.h>
#include <pthread.h>
#include <sched.h>
#include <time.h>

#include <atomic>
#include <chrono>
#include <mutex>
#include <thread>

#include "depowder/pi_mutex.hpp"

using namespace depowder;

namespace {

using Clock = std::chrono::steady_clock;

bool onCpu(int cpu) {
  cpu_set_t cpus;
  CPU_ZERO(&cpus);
  CPU_SET(cpu, &cpus);
  return pthread_setaffinity_np(pthread_self(), sizeof(cpus), &cpus) == 0;
}

// This thread at SCHED_FIFO `priority`, then on CPU 0 (in that order: a thread that reached CPU 0
// first would wait there behind the real-time ones); false if not permitted.
bool realtimeOnCpu0(int priority) {
  sched_param sp{};
  sp.sched_priority = priority;
  return pthread_setschedparam(pthread_self(), SCHED_FIFO, &sp) == 0 && onCpu(0);
}

double threadCpuMs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

// How long (ms) the high-priority thread waits for the lock; -1 if real-time scheduling is not
// permitted here. The calling thread must be on another CPU than 0 (it starts the others).
template <class Mutex>
double highPriorityWaitMs() {
  Mutex m;
  std::atomic<int> ready{0};  // 1: the holder has the lock; 2: the middle thread spins
  std::atomic<bool> permitted{true};
  double wait_ms = -1;
  std::thread low([&] {
    if (!realtimeOnCpu0(10)) permitted = false;
    std::lock_guard<Mutex> lock(m);
    ready = 1;
    while (ready < 2) std::this_thread::sleep_for(std::chrono::microseconds(100));  // held, not running
    const double start = threadCpuMs();
    while (threadCpuMs() - start < 5) {
    }
  });
  while (ready < 1) std::this_thread::yield();
  std::thread middle([&] {
    if (!realtimeOnCpu0(20)) permitted = false;
    ready = 2;
    const auto end = Clock::now() + std::chrono::milliseconds(100);
    while (Clock::now() < end) {
    }
  });
  while (ready < 2) std::this_thread::yield();
  std::thread high([&] {
    if (!realtimeOnCpu0(30)) permitted = false;
    const auto t0 = Clock::now();
    std::lock_guard<Mutex> lock(m);
    wait_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  });
  high.join();
  middle.join();
  low.join();
  return permitted ? wait_ms : -1;
}

}  // namespace

TEST(PiMutex, HighPriorityWaiterDoesNotWaitForMiddlePriorityWork) {
  cpu_set_t before;
  if (std::thread::hardware_concurrency() < 2 || pthread_getaffinity_np(pthread_self(), sizeof(before), &before) != 0 ||
      !CPU_ISSET(0, &before) || !CPU_ISSET(1, &before) || !onCpu(1))
    GTEST_SKIP() << "needs CPUs 0 and 1";
  const double plain = highPriorityWaitMs<std::mutex>();
  const double inherited = plain < 0 ? -1 : highPriorityWaitMs<PiMutex>();
  pthread_setaffinity_np(pthread_self(), sizeof(before), &before);
  if (plain < 0) GTEST_SKIP() << "SCHED_FIFO on CPU 0 not permitted here";
  std::printf("high-priority wait for the lock: std::mutex %.1f ms, PiMutex %.1f ms\n", plain, inherited);
  EXPECT_GT(plain, 80) << "the set-up should show the inversion with std::mutex";
  EXPECT_LT(inherited, 30);
}

TEST(PiMutex, IsLockable) {
  PiMutex m;
  {
    std::unique_lock<PiMutex> lock(m);
    EXPECT_FALSE(m.try_lock());
  }
  EXPECT_TRUE(m.try_lock());
  m.unlock();
}
