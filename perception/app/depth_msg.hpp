// depth_image_t <-> DepthImage + PinholeCamera (the executables' side of the library).
#pragma once

#include "depowder/depth_image_t.hpp"
#include "depowder/perception/depth.hpp"

namespace depowder::perception {

/// The frame and camera a message describes. A byte count that is odd or disagrees with
/// data[] is reported as kSizeMismatch; the rest is checked by deproject().
FrameError fromMsg(const depth_image_t& msg, DepthImage& image, PinholeCamera& camera);

/// The message for a frame of `camera` (what a camera driver or the simulator publishes).
depth_image_t toMsg(const DepthImage& image, const PinholeCamera& camera);

}  // namespace depowder::perception
