// Why a camera frame was or was not used. One enum for the whole pipeline, so the
// heartbeat can count drops by reason.
#pragma once

#include <array>
#include <cstdint>
#include <string>

namespace depowder::perception {

enum class FrameStatus {
  kOk = 0,
  kSizeMismatch,    ///< the depth buffer disagrees with width x height in the header
  kBadHeader,       ///< non-finite or impossible intrinsics, pose, ranges or depth unit
  kNoValidReturns,  ///< every pixel is 0 / NaN or out of range (a blind or dead frame)
  kLate,            ///< older than a time step that was already published
  kDuplicate,       ///< same camera and utime as a frame already waiting
  kAhead,           ///< stamped far ahead of the newest frame, and the camera's frame before was not
  kUnreadable,      ///< a recorded scan that could not be read (missing, corrupt)
  kCount
};

/// Short snake_case name, used as the heartbeat stat suffix ("dropped_size_mismatch").
const char* toString(FrameStatus status);

/// A frame's status and, when it is not kOk, a sentence saying what was wrong.
struct FrameError {
  FrameStatus status = FrameStatus::kOk;
  std::string message;
  bool ok() const { return status == FrameStatus::kOk; }
};

/// Frames counted by status (kOk = accepted).
using StatusCounts = std::array<std::int64_t, static_cast<std::size_t>(FrameStatus::kCount)>;

}  // namespace depowder::perception
