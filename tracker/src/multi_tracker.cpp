#include "depowder/tracker/multi_tracker.hpp"

#include <algorithm>
#include <thread>

#include "worker_pool.hpp"

namespace depowder::tracker {

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
