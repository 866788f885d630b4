// Cell files from the user (loadCellFromString): anything that is not a valid cell is a
// ConfigError naming what was wrong, never a crash or another exception.
#include <string>

#include "depowder/node/cell.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    depowder::node::loadCellFromString(std::string(reinterpret_cast<const char*>(data), size));
  } catch (const depowder::node::ConfigError&) {
  }
  return 0;
}
