#include "depowder/tracker/multi_tracker.hpp"

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <thread>

namespace depowder::tracker {

// A fixed set of threads that run `task(i)` for i in [0, n) and return when all are done.
// The calling thread works too, so `threads` = 1 means no extra thread at all.
class WorkerPool {
 public:
  explicit WorkerPool(int threads) {
    for (int k = 1; k < threads; ++k) workers_.emplace_back([this] { loop(); });
  }
  ~WorkerPool() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    wake_.notify_all();
    for (std::thread& t : workers_) t.join();
  }
  int threads() const { return static_cast<int>(workers_.size()) + 1; }

  void run(std::size_t n, const std::function<void(std::size_t)>& task) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      task_ = &task;
      n_ = n;
      next_ = 0;
      pending_ = n;
      ++generation_;
    }
    wake_.notify_all();
    work();
    std::unique_lock<std::mutex> lock(mutex_);
    done_.wait(lock, [&] { return pending_ == 0; });
    task_ = nullptr;
  }

 private:
  void loop() {
    std::uint64_t seen = 0;
    for (;;) {
      {
        std::unique_lock<std::mutex> lock(mutex_);
        wake_.wait(lock, [&] { return stop_ || generation_ != seen; });
        if (stop_) return;
        seen = generation_;
      }
      work();
    }
  }
  // Takes tasks until none are left. Tasks must not throw (PartTracker::track does not).
  void work() {
    for (;;) {
      const std::function<void(std::size_t)>* task = nullptr;
      std::size_t i = 0;
      {
        std::lock_guard<std::mutex> lock(mutex_);
        if (task_ == nullptr || next_ >= n_) return;
        task = task_;
        i = next_++;
      }
      (*task)(i);
      std::lock_guard<std::mutex> lock(mutex_);
      if (--pending_ == 0) done_.notify_all();
    }
  }

  std::vector<std::thread> workers_;
  std::mutex mutex_;
  std::condition_variable wake_, done_;
  const std::function<void(std::size_t)>* task_ = nullptr;
  std::size_t n_ = 0, next_ = 0, pending_ = 0;
  std::uint64_t generation_ = 0;
  bool stop_ = false;
};

MultiTracker::MultiTracker(std::vector<PartTracker> parts, int max_threads) : parts_(std::move(parts)) {
  const int cores = std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  int threads = max_threads > 0 ? max_threads : cores;
  threads = std::max(1, std::min({threads, cores, static_cast<int>(std::max<std::size_t>(parts_.size(), 1))}));
  pool_ = std::make_unique<WorkerPool>(threads);
}

MultiTracker::~MultiTracker() = default;

int MultiTracker::threads() const { return pool_->threads(); }

std::vector<TrackResult> MultiTracker::track(const Cloud& scan) {
  std::vector<TrackResult> results(parts_.size());
  // One task per part: each PartTracker owns its state; the scan is shared read-only.
  pool_->run(parts_.size(), [&](std::size_t i) { results[i] = parts_[i].track(scan); });
  return results;
}

std::vector<TrackResult> MultiTracker::track(const Cloud& scan, const std::vector<Point>& viewpoints) {
  std::vector<TrackResult> results(parts_.size());
  pool_->run(parts_.size(), [&](std::size_t i) { results[i] = parts_[i].track(scan, viewpoints); });
  return results;
}

}  // namespace depowder::tracker
