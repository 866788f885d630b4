// The tracker's last published pose per part, kept in a small file so that a restarted
// depowder-tracker resumes from where it left off instead of the cell's initial poses.
#pragma once

#include <cstdint>
#include <map>
#include <string>

#include "depowder/geometry.hpp"

namespace depowder::tracker {

struct SavedPose {
  Pose T_cell_part = Pose::Identity();
  std::int64_t utime = 0;  ///< of the POINTS frame it came from
};

/// One line per part: `name utime x y z qw qx qy qz`. Written to FILE.tmp and renamed, so a
/// reader never sees half a file. Returns "" or the error (the caller keeps running).
std::string saveTrackerState(const std::string& path, const std::map<std::string, SavedPose>& poses);

/// Reads a file written by saveTrackerState. A missing file is an empty state (a first start);
/// a malformed line, a non-finite or non-orthonormal pose throws std::runtime_error naming the
/// file and line.
std::map<std::string, SavedPose> loadTrackerState(const std::string& path);

}  // namespace depowder::tracker
