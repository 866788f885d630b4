// Conversions between the library types and the LCM messages, with validation.
#pragma once

#include <optional>
#include <string>

#include "depowder/geometry.hpp"
#include "depowder/point_cloud_t.hpp"
#include "depowder/pose_t.hpp"

namespace depowder::node {

pose_t toMsg(const Pose& pose);

/// The pose in `msg`, or nullopt with `why` set if it has NaN/inf or a quaternion
/// whose norm is not 1 (within 1e-3; smaller deviations are normalised away).
std::optional<Pose> fromMsg(const pose_t& msg, std::string* why = nullptr);

/// Quantises a cell-frame cloud (point_cloud_t: 6 bytes a point). Non-finite points and
/// points out of the int16 range around the cloud's centre are left out and counted in `dropped`.
point_cloud_t encodeCloud(const Cloud& cloud, std::int64_t utime, double resolution = 0.0005, int* dropped = nullptr);

/// The points of `msg` in metres, or nullopt with `why` if the header is invalid.
std::optional<Cloud> decodeCloud(const point_cloud_t& msg, std::string* why = nullptr);

/// Microseconds since the Unix epoch, now: for stamps, and for ages of stamped messages.
std::int64_t nowUtime();
/// Microseconds on a clock that only moves forward (since boot), now: for when a message arrived
/// and for waits, which a step of the system clock (NTP, an operator) must not stretch or cut.
std::int64_t steadyUtime();

}  // namespace depowder::node
