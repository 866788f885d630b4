// Recorded scans: PCD (any PCL-readable variant: ascii, binary, binary_compressed) and
// PLY point clouds (ascii, binary_little_endian; vertex x y z), organised or not, and a
// source that plays a directory of them in sorted order.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "depowder/geometry.hpp"
#include "depowder/perception/status.hpp"

namespace depowder::perception {

struct PointFile {
  FrameError error;  ///< kOk, or kUnreadable with a message naming the file and the fault
  Cloud points;      ///< as stored (NaN kept: organised scans mark missing pixels with NaN)
  int width = 0;     ///< organised scans: columns x rows; unorganised: points x 1
  int height = 0;
};

/// Reads a .pcd or .ply by extension (case-insensitive). Never throws for a bad file.
PointFile readPointFile(const std::string& path);
PointFile readPcd(const std::string& path);
PointFile readPly(const std::string& path);

/// The .pcd / .ply files of a directory, played in sorted (byte-wise) name order.
class FileSource {
 public:
  /// Lists `directory`; throws std::runtime_error if it cannot be read or holds no scan.
  explicit FileSource(const std::string& directory, bool loop = false);

  /// The next scan (its error says if it could not be read); false when the list is done.
  bool next(PointFile& scan, std::string* path = nullptr);

  const std::vector<std::string>& files() const { return files_; }

 private:
  std::vector<std::string> files_;
  std::size_t index_ = 0;
  bool loop_;
};

}  // namespace depowder::perception
