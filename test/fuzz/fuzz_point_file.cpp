// Recorded scans (readPointFile: PCD through PCL, PLY by hand): a malformed file is an error in
// the result, never a crash or an exception, and a scan that reads has width x height points.
// The first byte picks the format; the rest is the file.
#include <cstdlib>

#include "depowder/perception/point_file.hpp"
#include "fuzz.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const depowder::fuzz::TempFile file(data + 1, size - 1, data[0] % 2 ? ".pcd" : ".ply");
  const depowder::perception::PointFile scan = depowder::perception::readPointFile(file.path());
  if (scan.error.ok() && scan.points.size() != static_cast<std::size_t>(scan.width) * scan.height) std::abort();
  return 0;
}
