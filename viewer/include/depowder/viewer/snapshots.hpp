// When the snapshot modes write a picture, and under which name (no VTK, no IO).
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "depowder/viewer/scene.hpp"

namespace depowder::viewer {

struct SnapshotConfig {
  int every = 0;          ///< a picture every `every` POINTS frames (by seq); 0 = off
  bool on_phase = false;  ///< a picture whenever a part's phase changes (first phase included)
  /// After a POINTS frame is due, wait up to this long for the PART_POSE of that frame
  /// (every part the tracker has spoken about), so the picture shows one frame's state.
  double settle_s = 0.5;
};

/// Fed the scene after each batch of messages; says which pictures to write now.
class SnapshotPolicy {
 public:
  explicit SnapshotPolicy(SnapshotConfig config) : config_(config) {}

  /// File names (without directory, with ".png") to write from the current scene.
  /// `now_s` is any monotonic clock in seconds.
  std::vector<std::string> due(const Scene& scene, double now_s);
  /// Pictures still waiting for their frame's poses, to write now (end of a log or run).
  std::vector<std::string> flush();

 private:
  struct Pending {
    std::string name;
    std::int64_t utime = 0;
    double since_s = 0;
  };
  bool settled(const Scene& scene, const Pending& p, double now_s) const;

  SnapshotConfig config_;
  std::int64_t last_bucket_ = -1;
  std::vector<Pending> pending_;
  std::map<std::string, int> phases_;  ///< last phase seen per part
};

/// "points-000120.png" for POINTS seq 120.
std::string pointsSnapshotName(std::int64_t seq);
/// "pipe-phase2-tracked.png".
std::string phaseSnapshotName(const std::string& part, int phase);

}  // namespace depowder::viewer
