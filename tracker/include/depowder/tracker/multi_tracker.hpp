// Every part of the cell tracked in parallel on a small pool of threads, one part per
// task (the paper's two-cube demo, Sec. V-E: "two tracking processes in parallel").
#pragma once

#include <memory>
#include <vector>

#include "depowder/tracker/part_tracker.hpp"

namespace depowder::tracker {

class WorkerPool;

class MultiTracker {
 public:
  /// `max_threads` 0: one per part, bounded by the machine's cores.
  explicit MultiTracker(std::vector<PartTracker> parts, int max_threads = 0);
  ~MultiTracker();
  MultiTracker(const MultiTracker&) = delete;
  MultiTracker& operator=(const MultiTracker&) = delete;

  /// Tracks every part on `scan`; results in the order of the parts.
  std::vector<TrackResult> track(const Cloud& scan);
  /// The same with this frame's camera positions (PartTracker::track).
  std::vector<TrackResult> track(const Cloud& scan, const std::vector<Point>& viewpoints);

  std::size_t size() const { return parts_.size(); }
  int threads() const;
  PartTracker& part(std::size_t i) { return parts_[i]; }
  const PartTracker& part(std::size_t i) const { return parts_[i]; }

 private:
  std::vector<PartTracker> parts_;
  std::unique_ptr<WorkerPool> pool_;
};

}  // namespace depowder::tracker
