// Messages the process and tool tests send or record as a cell process would.
#pragma once

#include <cstdint>
#include <string>

#include "depowder/geometry.hpp"
#include "depowder/node/convert.hpp"
#include "depowder/part_pose_t.hpp"

namespace depowder::testutil {

/// CU-ICP's PART_POSE for `part` at T_cell_part, TRACKING, with no template.
inline part_pose_t trackingPose(const std::string& part, std::int64_t utime, const Pose& T_cell_part) {
  part_pose_t m{};
  m.utime = utime;
  m.part = part;
  m.method = "cu";
  m.status = part_pose_t::TRACKING;
  m.T_cell_part = node::toMsg(T_cell_part);
  m.template_size = 0;
  return m;
}

}  // namespace depowder::testutil
