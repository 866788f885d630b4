// depowder-eval's JSON (results read back by `report`): a malformed document is a JsonError, and
// one that parses dumps to text that parses to the same dump.
#include <cstdlib>
#include <string>

#include "depowder/eval/json.hpp"

using depowder::eval::Json;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const Json doc = Json::parse(std::string(reinterpret_cast<const char*>(data), size));
    const std::string text = doc.dump();
    if (Json::parse(text).dump() != text) std::abort();
  } catch (const depowder::eval::JsonError&) {
  }
  return 0;
}
