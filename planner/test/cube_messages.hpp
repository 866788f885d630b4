// The one-cube cell and the messages the planner's process tests send it: a cell YAML with the
// default cell's arm and a 25 cm nozzle (see fixtures.hpp), a PART_POSE and a PROGRESS for the
// cube at a pose, the PROGRESS with fixtures.hpp's synthetic contour.
#pragma once

#include <cstdint>
#include <string>

#include "depowder/node/convert.hpp"
#include "depowder/part_pose_t.hpp"
#include "depowder/parts.hpp"
#include "depowder/progress_t.hpp"
#include "depowder/test_messages.hpp"
#include "fixtures.hpp"

namespace depowder::planner::test {

inline std::string cubeCellYaml(const std::string& planner_section = "planner: {}\n") {
  return "parts:\n  - name: cube\n    mesh: " + std::string(DEPOWDER_SOURCE_DIR) +
         "/config/parts/cube.stl\n    initial_pose: {xyz: [0.0, 0.0, 0.03], rpy_deg: [0, 0, 0]}\n"
         "robot:\n  base_pose: {xyz: [-0.55, 0, 0], rpy_deg: [0, 0, 0]}\n"
         "  tool_offset: {xyz: [0, 0, 0.25], rpy_deg: [0, 0, 0]}\n" +
         planner_section;
}

inline part_pose_t cubePose(std::int64_t utime, const Pose& T) { return testutil::trackingPose("cube", utime, T); }

/// The powder surface at height `powder`, eta 0.5, in the second vacuum phase.
inline progress_t cubeProgress(std::int64_t utime, const Pose& T, double powder) {
  progress_t m = testutil::vacuumProgress("cube", utime, T, 0.5);
  m.h_pow = powder;
  m.h_max = T.translation().z() + 0.03;
  m.h_min = T.translation().z() - 0.03;
  for (const Point& p : syntheticContour(transformed(parts::byName("cube"), T), powder))
    m.contour.push_back({static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())});
  m.num_contour = static_cast<std::int32_t>(m.contour.size());
  return m;
}

}  // namespace depowder::planner::test
