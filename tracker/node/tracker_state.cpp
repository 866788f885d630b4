#include "tracker_state.hpp"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace depowder::tracker {

std::string saveTrackerState(const std::string& path, const std::map<std::string, SavedPose>& poses) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::trunc);
    if (!out) return "cannot write " + tmp + ": " + std::strerror(errno);
    out.precision(17);
    for (const auto& [name, p] : poses) {
      const Eigen::Vector3d t = p.T_cell_part.translation();
      const Eigen::Quaterniond q(p.T_cell_part.linear());
      out << name << ' ' << p.utime << ' ' << t.x() << ' ' << t.y() << ' ' << t.z() << ' ' << q.w() << ' ' << q.x()
          << ' ' << q.y() << ' ' << q.z() << '\n';
    }
    if (!out.flush()) return "cannot write " + tmp + ": " + std::strerror(errno);
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) return "cannot rename " + tmp + ": " + std::strerror(errno);
  return "";
}

std::map<std::string, SavedPose> loadTrackerState(const std::string& path) {
  std::map<std::string, SavedPose> poses;
  // None yet: a first start. Anything else that cannot be read (a directory, no permission) is
  // said, not taken for a first start.
  std::error_code ec;
  const auto type = std::filesystem::status(path, ec).type();
  if (type == std::filesystem::file_type::not_found) return poses;
  if (type != std::filesystem::file_type::regular)
    throw std::runtime_error(path + ": not a regular file" + (ec ? " (" + ec.message() + ")" : std::string()));
  errno = 0;
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot be read: " + std::strerror(errno));
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    if (line.empty()) continue;
    std::istringstream s(line);
    std::string name, rest;
    SavedPose p;
    double x, y, z, qw, qx, qy, qz;
    const auto fail = [&](const std::string& why) {
      return std::runtime_error(path + ":" + std::to_string(n) + ": " + why);
    };
    if (!(s >> name >> p.utime >> x >> y >> z >> qw >> qx >> qy >> qz) || (s >> rest))
      throw fail("expected 'name utime x y z qw qx qy qz'");
    const Eigen::Quaterniond q(qw, qx, qy, qz);
    if (!std::isfinite(q.norm()) || std::abs(q.norm() - 1.0) > 1e-6) throw fail("the quaternion is not a unit one");
    p.T_cell_part = makePose({x, y, z}, q);
    if (!isValidPose(p.T_cell_part)) throw fail("the pose is not finite");
    poses[name] = p;
  }
  return poses;
}

}  // namespace depowder::tracker
