// depowder-calibrate: each depth camera's extrinsics refined against the build box
// (depowder/perception/box_calibration.hpp), from live DEPTH_* frames or a recorded log.
// It prints what it found and the pose to put in the cell file; it changes no file.
#include <cstdlib>
#include <iomanip>
#include <iostream>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <set>

#include "depowder/depth_image_t.hpp"
#include "depowder/node/bus.hpp"
#include "depowder/node/cell.hpp"
#include "depowder/node/log_reader.hpp"
#include "depowder/node/shutdown.hpp"
#include "depowder/perception/box_calibration.hpp"
#include "depth_msg.hpp"

using namespace depowder;
using namespace depowder::perception;

namespace {

int usage(const std::string& error = "") {
  if (!error.empty()) std::cerr << "depowder-calibrate: " << error << "\n";
  std::cerr << "usage: depowder-calibrate [--cell FILE] [--log FILE] [--frames N] [--camera NAME] [--timeout S]\n"
               "                          [--url URL] [--prefix P]\n"
               "  Refines each camera's T_cell_camera against the build box of the cell file: the rim, the walls\n"
               "  and a flat powder surface (calibrate before a run, parts covered or standing still). The pose\n"
               "  each DEPTH_<NAME> frame carries is the first guess; it must be within a few cm and degrees.\n"
               "  --cell FILE    cell YAML (default: $DEPOWDER_CELL or config/cell.yaml); --config is the same\n"
               "  --log FILE     read the frames from an LCM log (lcm-logger) instead of the bus\n"
               "  --frames N     frames per camera, merged per pixel by their median (default 30)\n"
               "  --camera NAME  only this camera (default: every camera of the cell file)\n"
               "  --timeout S    seconds to wait for the frames on the bus (default 10)\n"
               "  --url URL, --prefix P   LCM URL and channel prefix (override lcm.url and lcm.prefix)\n"
               "  Exit status: 0 every camera calibrated, 1 one or more could not be, 2 bad usage.\n";
  return error.empty() ? 0 : 2;
}

struct CameraFrames {
  PinholeCamera camera;  ///< as the newest frame describes it
  std::vector<DepthImage> frames;
  std::string last_error;
  int rejected = 0;
};

std::ostream& printPose(std::ostream& os, const Pose& T) {
  const Eigen::Quaterniond q(T.linear());
  const Eigen::Vector3d t = T.translation();
  os << std::fixed << "pose: {xyz: [" << std::setprecision(5) << t.x() << ", " << t.y() << ", " << t.z()
     << "], quat_wxyz: [" << std::setprecision(7) << q.w() << ", " << q.x() << ", " << q.y() << ", " << q.z() << "]}";
  os.unsetf(std::ios::floatfield);
  return os;
}

// One camera's report; true when it was calibrated.
bool report(const std::string& name, const CameraFrames& f, const node::CellConfig& cell) {
  std::cout << name << ": ";
  if (f.frames.empty()) {
    std::cout << "no usable frame on DEPTH_" << name;
    if (f.rejected) std::cout << " (" << f.rejected << " rejected; the last: " << f.last_error << ")";
    std::cout << "\n";
    return false;
  }
  const DepthImage merged = medianDepth(f.frames);
  PinholeCamera at_origin = f.camera;
  at_origin.T_cell_camera = Pose::Identity();
  const Eigen::AlignedBox3d everywhere(Eigen::Vector3d::Constant(-1e3), Eigen::Vector3d::Constant(1e3));
  const CameraCloud cloud = deproject(merged, at_origin, everywhere);
  if (!cloud.error.ok()) {
    std::cout << f.frames.size() << " frames, " << cloud.error.message << "\n";
    return false;
  }
  const BoxCalibration c = calibrateAgainstBox(cloud.points, f.camera.T_cell_camera, cell.box.size, cell.box.wall);
  std::cout << f.frames.size() << " frames, " << cloud.points.size() << " points, " << c.points
            << " of them on the box\n";
  for (const node::CameraConfig& cc : cell.cameras)
    if (cc.name == name && (translationDistance(cc.T_cell_camera, f.camera.T_cell_camera) > 1e-4 ||
                            rotationDistanceDeg(cc.T_cell_camera, f.camera.T_cell_camera) > 0.01))
      std::cout << "  the frames carry a pose " << 1000 * translationDistance(cc.T_cell_camera, f.camera.T_cell_camera)
                << " mm and " << rotationDistanceDeg(cc.T_cell_camera, f.camera.T_cell_camera)
                << " deg from the cell file's; the frames' is the first guess\n";
  if (!c.ok) {
    std::cout << "  not calibrated: " << c.problem << "\n";
    return false;
  }
  std::cout << std::setprecision(3) << "  moved " << 1000 * translationDistance(c.T_cell_camera, f.camera.T_cell_camera)
            << " mm and turned " << rotationDistanceDeg(c.T_cell_camera, f.camera.T_cell_camera)
            << " deg from the frames' pose\n"
            << "  points to the box (median): " << 1000 * c.median_before << " mm before, " << 1000 * c.median_after
            << " mm after; the powder at z = " << 1000 * c.powder_level << " mm\n"
            << (c.median_after > 0.0015 ? "  the points lie far from the box (median over 1.5 mm): is the powder flat, "
                                          "and the cell file's box the one in view?\n"
                                        : "")
            << "  pinned to +-" << 1000 * c.sigma_t.maxCoeff() << " mm and +-" << c.sigma_r.maxCoeff() * 180 / M_PI
            << " deg (noise alone)\n"
            << "  in the cell file's cameras entry " << name << ", in place of position and look_at (or pose):\n    ";
  printPose(std::cout, c.T_cell_camera) << "\n";
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  std::string cell_path = node::defaultCellPath(), log_path, only, url, prefix;
  bool have_url = false, have_prefix = false;
  int want = 30;
  double timeout = 10;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") return usage();
    if (i + 1 >= argc) return usage("missing value after " + a);
    const std::string v = argv[++i];
    if (a == "--cell" || a == "--config")
      cell_path = v;
    else if (a == "--log")
      log_path = v;
    else if (a == "--camera")
      only = v;
    else if (a == "--url")
      url = v, have_url = true;
    else if (a == "--prefix")
      prefix = v, have_prefix = true;
    else if (a == "--frames" || a == "--timeout") {
      char* end = nullptr;
      const double x = std::strtod(v.c_str(), &end);
      if (end == v.c_str() || *end || !(x > 0) || x > 1e5)
        return usage(a + " takes a positive number, not '" + v + "'");
      if (a == "--frames")
        want = static_cast<int>(x);
      else
        timeout = x;
    } else {
      return usage("unknown option " + a);
    }
  }
  try {
    const node::CellConfig cell = node::loadCell(cell_path);
    if (!have_url) url = cell.lcm.url;
    if (!have_prefix) prefix = cell.lcm.prefix;
    std::set<std::string> wanted;
    for (const node::CameraConfig& c : cell.cameras)
      if (only.empty() || c.name == only) wanted.insert(c.name);
    if (!only.empty() && wanted.empty()) wanted.insert(only);  // a camera the cell file does not list yet
    if (wanted.empty()) return usage("the cell file lists no camera; name one with --camera");

    std::map<std::string, CameraFrames> got;
    auto take = [&](const depth_image_t& msg) {
      if (!wanted.count(msg.camera)) return;
      CameraFrames& f = got[msg.camera];
      if (static_cast<int>(f.frames.size()) >= want) return;
      DepthImage image;
      PinholeCamera camera;
      FrameError e = fromMsg(msg, image, camera);
      if (e.ok()) e = checkDepthImage(image, camera);
      if (!e.ok()) {
        ++f.rejected;
        f.last_error = e.message;
        return;
      }
      // The pixels are merged by their median: a camera that changed its resolution or depth unit
      // starts its frames over, so all of them are of its newest mode.
      const PinholeCamera before = f.camera;
      f.camera = camera;
      if (const std::size_t dropped = addMedianFrame(f.frames, std::move(image)))
        std::cerr << "depowder-calibrate: " << msg.camera << " changed from " << before.width << "x" << before.height
                  << " to " << camera.width << "x" << camera.height << " pixels (or its depth unit): its " << dropped
                  << " frames so far are dropped\n";
    };
    auto done = [&] {
      for (const std::string& name : wanted)
        if (!got.count(name) || static_cast<int>(got[name].frames.size()) < want) return false;
      return true;
    };
    if (!log_path.empty()) {
      node::LogReader log(log_path);
      const std::string channel = prefix + "DEPTH_";
      for (const lcm::LogEvent* e; !done() && (e = log.next()) != nullptr;) {
        if (e->channel.compare(0, channel.size(), channel) != 0) continue;
        depth_image_t msg;
        if (msg.decode(e->data, 0, e->datalen) < 0) {
          std::cerr << "depowder-calibrate: a corrupt message on " << e->channel << " skipped\n";
          continue;
        }
        take(msg);
      }
      for (const node::LogDamage& d : log.damage()) std::cerr << "depowder-calibrate: " << node::describe(d) << "\n";
    } else {
      node::installShutdownHandlers();
      node::Bus bus(url, prefix);
      bus.subscribe<depth_image_t>("DEPTH_.*", [&](const depth_image_t& m, const std::string&) { take(m); });
      bus.spinUntil([&] { return done() || node::shutdownRequested(); }, timeout);
    }
    bool all = true;
    for (const std::string& name : wanted) all = report(name, got[name], cell) && all;
    return all ? 0 : 1;
  } catch (const std::exception& e) {
    std::cerr << "depowder-calibrate: " << e.what() << "\n";
    return 1;
  }
}
