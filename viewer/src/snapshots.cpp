#include "depowder/viewer/snapshots.hpp"

#include <cctype>
#include <cstdio>

namespace depowder::viewer {

std::string pointsSnapshotName(std::int64_t seq) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "points-%06lld.png", static_cast<long long>(seq));
  return buf;
}

std::string phaseSnapshotName(const std::string& part, int phase) {
  std::string safe;
  for (char c : part) safe += (std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_') ? c : '_';
  return safe + "-phase" + std::to_string(phase) + "-" + phaseSlug(phase) + ".png";
}

bool SnapshotPolicy::settled(const Scene& scene, const Pending& p, double now_s) const {
  if (now_s - p.since_s >= config_.settle_s) return true;
  for (const PartScene& part : scene.parts)
    if (part.has_estimate && part.pose_utime < p.utime) return false;
  return true;
}

std::vector<std::string> SnapshotPolicy::due(const Scene& scene, double now_s) {
  std::vector<std::string> names;
  if (config_.every > 0 && scene.cloud_seq >= 0) {
    const std::int64_t bucket = scene.cloud_seq / config_.every;
    if (bucket != last_bucket_) {
      // A newer frame is due: an older one still waiting is written as it is now.
      for (const Pending& p : pending_) names.push_back(p.name);
      pending_.clear();
      pending_.push_back({pointsSnapshotName(scene.cloud_seq), scene.cloud_utime, now_s});
      last_bucket_ = bucket;
    }
  }
  for (auto it = pending_.begin(); it != pending_.end();) {
    if (settled(scene, *it, now_s)) {
      names.push_back(it->name);
      it = pending_.erase(it);
    } else {
      ++it;
    }
  }
  if (config_.on_phase) {
    for (const PartScene& part : scene.parts) {
      if (!part.has_progress) continue;
      auto [it, inserted] = phases_.emplace(part.name, part.phase);
      if (inserted || it->second != part.phase) {
        it->second = part.phase;
        names.push_back(phaseSnapshotName(part.name, part.phase));
      }
    }
  }
  return names;
}

std::vector<std::string> SnapshotPolicy::flush() {
  std::vector<std::string> names;
  for (const Pending& p : pending_) names.push_back(p.name);
  pending_.clear();
  return names;
}

}  // namespace depowder::viewer
