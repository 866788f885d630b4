// A mutex with priority inheritance (PTHREAD_PRIO_INHERIT), for state that a real-time thread
// shares with lower-priority ones. With std::mutex, a low-priority holder preempted by
// middle-priority work (a render, a plan) keeps the real-time thread waiting for as long as that
// work runs: priority inversion. Here the waiter lends the holder its priority until it unlocks.
// Lockable: use it with std::lock_guard and std::unique_lock.
#pragma once

#include <pthread.h>

#include <system_error>

namespace depowder {

class PiMutex {
 public:
  PiMutex() {
    pthread_mutexattr_t attr;
    pthread_mutexattr_init(&attr);
    pthread_mutexattr_setprotocol(&attr, PTHREAD_PRIO_INHERIT);
    const int e = pthread_mutex_init(&m_, &attr);
    pthread_mutexattr_destroy(&attr);
    if (e != 0) throw std::system_error(e, std::generic_category(), "pthread_mutex_init (priority inheritance)");
  }
  ~PiMutex() { pthread_mutex_destroy(&m_); }
  PiMutex(const PiMutex&) = delete;
  PiMutex& operator=(const PiMutex&) = delete;

  void lock() {
    const int e = pthread_mutex_lock(&m_);
    if (e != 0) throw std::system_error(e, std::generic_category(), "pthread_mutex_lock");
  }
  bool try_lock() { return pthread_mutex_trylock(&m_) == 0; }
  void unlock() { pthread_mutex_unlock(&m_); }

 private:
  pthread_mutex_t m_;
};

}  // namespace depowder
