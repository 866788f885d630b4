// Number formatting for human-readable reasons (internal to the tracker library).
#pragma once

#include <cstdio>
#include <string>

namespace depowder::tracker::detail {

/// `value` with `decimals` digits after the point.
inline std::string fixed(double value, int decimals = 2) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, value);
  return buf;
}

}  // namespace depowder::tracker::detail
