// Recorded scans (readPointFile: PCD through PCL, PLY by hand): a malformed file is an error in
// the result, never a crash or an exception, and a scan that reads has width x height points.
// The first byte picks the format; the rest is the file.
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "depowder/perception/point_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const std::string path = (std::filesystem::temp_directory_path() / "depowder-fuzz-").string() +
                           std::to_string(::getpid()) + (data[0] % 2 ? ".pcd" : ".ply");
  std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(data + 1), size - 1);
  const depowder::perception::PointFile scan = depowder::perception::readPointFile(path);
  ::unlink(path.c_str());
  if (scan.error.ok() && scan.points.size() != static_cast<std::size_t>(scan.width) * scan.height) std::abort();
  return 0;
}
