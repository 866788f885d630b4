// The nozzle: its tube's default size, and its tool state (what a plan asks for,
// waypoint_t.tool, what the driver switches on the controller's I/O and what the simulator's
// nozzle does to the powder).
#pragma once

#include <cstdint>

namespace depowder {

/// The cleaning nozzle's tube, m: its radius and its length up its axis from the tip. The defaults
/// of planner.nozzle, which the other processes read (node::readTool).
inline constexpr double kNozzleRadius = 0.0125, kNozzleLength = 0.13;

/// Tool states; the values equal waypoint_t::TOOL_*.
enum class Tool : std::int8_t { kOff = 0, kVacuum = 1, kAir = 2 };

inline const char* toString(Tool tool) {
  switch (tool) {
    case Tool::kOff:
      return "off";
    case Tool::kVacuum:
      return "vacuum";
    case Tool::kAir:
      return "air";
  }
  return "?";
}

}  // namespace depowder
