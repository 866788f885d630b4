// Messages the process and tool tests send or record as a cell process would.
#pragma once

#include <cstdint>
#include <string>

#include "depowder/geometry.hpp"
#include "depowder/node/convert.hpp"
#include "depowder/part_pose_t.hpp"
#include "depowder/progress_t.hpp"

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

/// The progress process's PROGRESS for `part` at T_cell_part: the second vacuum phase, OK, at `eta`,
/// with no contour and no band.
inline progress_t vacuumProgress(const std::string& part, std::int64_t utime, const Pose& T_cell_part, double eta) {
  progress_t m{};
  m.utime = utime;
  m.part = part;
  m.phase = progress_t::PHASE_VACUUM_TRACKED;
  m.status = progress_t::OK;
  m.eta = eta;
  m.eta_raw = eta;
  m.T_cell_part = node::toMsg(T_cell_part);
  m.num_contour = m.num_band = 0;
  return m;
}

}  // namespace depowder::testutil
