#include "depowder/perception/point_file.hpp"

#include <algorithm>
#include <filesystem>
#include <stdexcept>

#include "depowder/files.hpp"
#include "depowder/ply.hpp"

namespace depowder::perception {

PointFile readPly(const std::string& path) {
  PointFile out;
  const std::optional<std::string> bytes = readFile(path);
  if (!bytes) {
    out.error = {FrameStatus::kUnreadable, path + ": cannot open the file"};
    return out;
  }
  try {
    out.points = parsePly(*bytes, false).vertices;
  } catch (const PlyError& e) {
    out.error = {FrameStatus::kUnreadable, path + ": not a readable PLY point cloud: " + e.what()};
    return out;
  }
  out.width = static_cast<int>(out.points.size());
  out.height = 1;
  return out;
}

PointFile readPointFile(const std::string& path) {
  const std::string ext = lowerExtension(path);
  if (ext == ".pcd") return readPcd(path);
  if (ext == ".ply") return readPly(path);
  PointFile out;
  out.error = {FrameStatus::kUnreadable, path + ": not a .pcd or .ply file"};
  return out;
}

FileSource::FileSource(const std::string& directory, bool loop) : loop_(loop) {
  std::error_code ec;
  std::filesystem::directory_iterator it(directory, ec);
  if (ec) throw std::runtime_error("cannot list scan directory '" + directory + "': " + ec.message());
  for (const auto& entry : it) {
    const std::string ext = lowerExtension(entry.path().string());
    if ((ext == ".pcd" || ext == ".ply") && !entry.is_directory()) files_.push_back(entry.path().string());
  }
  if (files_.empty()) throw std::runtime_error("scan directory '" + directory + "' holds no .pcd or .ply file");
  std::sort(files_.begin(), files_.end());
}

bool FileSource::next(PointFile& scan, std::string* path) {
  if (index_ >= files_.size()) {
    if (!loop_) return false;
    index_ = 0;
  }
  const std::string& file = files_[index_++];
  if (path) *path = file;
  scan = readPointFile(file);
  return true;
}

}  // namespace depowder::perception
