// Messages the process and tool tests send or record as a cell process would, and writing one to
// an LCM log as lcm-logger would.
#pragma once

#include <cstdint>
#include <lcm/lcm-cpp.hpp>
#include <string>
#include <vector>

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

/// `msg` as it goes on the wire (and into a log).
template <class Msg>
std::vector<std::uint8_t> encoded(const Msg& msg) {
  std::vector<std::uint8_t> data(static_cast<std::size_t>(msg.getEncodedSize()));
  msg.encode(data.data(), 0, static_cast<int>(data.size()));
  return data;
}

/// Appends `data` on `channel` to `log` at `timestamp` (utime); LogFile::writeEvent's result (0: written).
inline int writeBytes(lcm::LogFile& log, const std::string& channel, std::vector<std::uint8_t> data,
                      std::int64_t timestamp) {
  lcm::LogEvent e{0, timestamp, channel, static_cast<std::int32_t>(data.size()), data.data()};
  return log.writeEvent(&e);
}

/// Appends `msg` on `channel` to `log` at `timestamp` (utime); LogFile::writeEvent's result (0: written).
template <class Msg>
int writeMessage(lcm::LogFile& log, const std::string& channel, const Msg& msg, std::int64_t timestamp) {
  return writeBytes(log, channel, encoded(msg), timestamp);
}

}  // namespace depowder::testutil
