#include "camera_options.hpp"

#include <cstdlib>
#include <sstream>
#include <stdexcept>
#include <utility>

namespace depowder::perception {

namespace {

void readSection(const node::YamlReader& r, CameraNodeOptions& o) {
  PerceptionConfig& p = o.perception;
  r.read("input", o.input);
  r.read("output", o.output);
  r.read("heartbeat_period", o.heartbeat_period, 0.05, 10.0);
  r.read("recv_buf_size", o.recv_buf_size, 0, 1 << 30);
  r.read("crop_margin", p.crop_margin, 0.0, 0.5);
  r.read("voxel_leaf", p.voxel_leaf, 0.001, 0.05);
  r.read("outlier_min_neighbours", p.outlier_min_neighbours, 0, 26);
  r.read("resolution", p.resolution, 0.0001, 0.01);
  r.read("match_tolerance", p.merger.match_tolerance, 0.0, 1.0);
  r.read("max_wait", p.merger.max_wait, 0.0, 5.0);
  r.read("silent_after", p.merger.silent_after, 0.01, 60.0);
  r.read("stale_after", p.merger.stale_after, 0.01, 60.0);
  r.read("robot_state", o.robot_state);
  const node::YamlReader sf = r.child("self_filter");
  sf.read("radius", p.self_filter.radius, 0.0, 0.5);
  sf.read("length", p.self_filter.length, 0.0, 2.0);
  node::readEffector(sf, "effector", p.self_filter.effector);
  sf.read("margin", p.self_filter.margin, -1.0, 0.2);
  sf.read("max_age", p.self_filter.max_age, 0.0, 1.0);
  sf.finish();
  const node::YamlReader ag = r.child("agreement");
  AgreementConfig& a = p.agreement;
  ag.read("period", a.period, -1.0, 3600.0);
  ag.read("cell", a.cell, 0.002, 0.1);
  ag.read("wall_margin", a.wall_margin, 0.0, 0.5);
  ag.read("min_points", a.min_points, 1, 1000);
  ag.read("min_cells", a.min_cells, 3, 1000000);
  ag.read("max_offset", a.max_offset, 0.0, 0.1);
  ag.read("max_tilt_deg", a.max_tilt_deg, 0.0, 45.0);
  ag.read("flag_after", a.flag_after, 1, 1000);
  ag.finish();
  const node::YamlReader f = r.child("files");
  FilesConfig& files = o.files;
  f.read("dir", files.dir);
  if (!files.dir.empty() && files.dir[0] != '/' && !f.directory().empty()) files.dir = f.directory() + "/" + files.dir;
  f.read("rate_hz", files.rate_hz, 0.01, 1000.0);
  f.read("loop", files.loop);
  f.read("camera", files.camera.name);
  f.readPose("pose", files.camera.T_cell_camera);
  f.read("min_range", files.camera.min_range, 0.0, 100.0);
  f.read("max_range", files.camera.max_range, 0.001, 1000.0);
  if (files.camera.max_range <= files.camera.min_range) f.fail("max_range", "must be greater than min_range");
  f.finish();
  r.finish();
}

// "x,y,z,roll,pitch,yaw" (m, deg) -> pose.
Pose parsePose(const std::string& text) {
  std::istringstream s(text);
  double v[6];
  char comma = 0;
  for (int i = 0; i < 6; ++i) {
    if (!(s >> v[i]) || (i < 5 && (!(s >> comma) || comma != ',')))
      throw std::invalid_argument("--camera-pose wants x,y,z,roll,pitch,yaw (m, deg), got '" + text + "'");
  }
  const double k = M_PI / 180.0;
  return makePoseRpy({v[0], v[1], v[2]}, v[3] * k, v[4] * k, v[5] * k);
}

double parseNumber(const std::string& flag, const std::string& text, double lo, double hi) {
  std::size_t used = 0;
  double v = 0;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() || !(v >= lo && v <= hi)) {
    std::ostringstream s;
    s << flag << " wants a number in [" << lo << ", " << hi << "], got '" << text << "'";
    throw std::invalid_argument(s.str());
  }
  return v;
}

}  // namespace

std::string lcmUrl(const std::string& url, int recv_buf_size) {
  std::string u = url;
  if (u.empty()) {
    const char* env = std::getenv("LCM_DEFAULT_URL");
    u = env && *env ? env : "udpm://239.255.76.67:7667?ttl=0";
  }
  if (recv_buf_size > 0 && u.rfind("udpm://", 0) == 0 && u.find("recv_buf_size=") == std::string::npos)
    u += (u.find('?') == std::string::npos ? "?" : "&") + std::string("recv_buf_size=") + std::to_string(recv_buf_size);
  return u;
}

std::string usage() {
  return "usage: depowder-camera [options]\n"
         "  Live: subscribes DEPTH_* (depth_image_t), publishes POINTS (point_cloud_t) in the cell frame.\n"
         "  Files: plays a directory of .pcd / .ply scans (sorted) instead.\n"
         "options:\n"
         "  --cell FILE          cell YAML (default: $DEPOWDER_CELL or config/cell.yaml)\n"
         "  --files DIR          recorded scans instead of live frames (or perception.files.dir)\n"
         "  --rate HZ            scans per second in files mode (default 10)\n"
         "  --loop               replay the scans forever\n"
         "  --camera-pose P      T_cell_camera of the scans: x,y,z,roll,pitch,yaw (m, deg)\n"
         "  --camera-name NAME   name the scans' source (default FILES)\n"
         "  --url URL            LCM URL (overrides lcm.url)\n"
         "  --prefix P           channel prefix (overrides lcm.prefix)\n"
         "  --verbose            print every rejected frame (default: at most one line a second per reason)\n";
}

CameraNodeOptions readCameraOptions(node::CellConfig cell) {
  CameraNodeOptions o(std::move(cell));
  o.files.camera.name = "FILES";
  // The self-filter's nozzle and end effector are the cell's tool, unless perception.self_filter
  // gives its own.
  const node::ToolConfig tool = node::readTool(o.cell);
  SelfFilterConfig& sf = o.perception.self_filter;
  sf.radius = tool.nozzle_radius;
  sf.length = tool.tube_length;
  sf.effector = tool.effector;
  sf.T_flange_nozzle = tool.T_flange_nozzle;
  readSection(o.cell.root.child("perception"), o);
  return o;
}

std::optional<CameraNodeOptions> parseOptions(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  std::string cell_path = node::defaultCellPath();
  for (std::size_t i = 0; i < args.size(); ++i) {
    if (args[i] == "--help" || args[i] == "-h") return std::nullopt;
    if (args[i] == "--cell" && i + 1 < args.size()) cell_path = args[i + 1];
  }
  CameraNodeOptions o = readCameraOptions(node::loadCell(cell_path));
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    auto value = [&]() -> const std::string& {
      if (i + 1 >= args.size()) throw std::invalid_argument(a + " needs a value");
      return args[++i];
    };
    if (a == "--help" || a == "-h") return std::nullopt;
    if (a == "--cell")
      value();
    else if (a == "--files")
      o.files.dir = value();
    else if (a == "--rate")
      o.files.rate_hz = parseNumber(a, value(), 0.01, 1000.0);
    else if (a == "--loop")
      o.files.loop = true;
    else if (a == "--camera-pose")
      o.files.camera.T_cell_camera = parsePose(value());
    else if (a == "--camera-name")
      o.files.camera.name = value();
    else if (a == "--url")
      o.cell.lcm.url = value();
    else if (a == "--prefix")
      o.cell.lcm.prefix = value();
    else if (a == "--verbose")
      o.verbose = true;
    else
      throw std::invalid_argument("unknown option '" + a + "'\n" + usage());
  }
  return o;
}

}  // namespace depowder::perception
