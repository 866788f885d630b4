#include "depowder/perception/box_calibration.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>
#include <vector>

namespace depowder::perception {

namespace {

// One planar face of the box: coordinate[axis] = value, the other two within [lo, hi], seen
// from the side `normal` (+1 or -1 along the axis) points to. The powder's face has the
// unknown level as its value.
struct Face {
  int axis = 2;
  int normal = 1;
  double value = 0;
  Eigen::Vector3d lo, hi;
  bool powder = false;
};

std::vector<Face> boxFaces(const Eigen::Vector3d& size, double w, double level) {
  const double X = 0.5 * size.x(), Y = 0.5 * size.y(), H = size.z();
  const double _ = 0;  // the entry on a face's own axis is unused
  return {
      {2, +1, level, {-X, -Y, _}, {X, Y, _}, true},          // powder
      {0, +1, -X, {_, -Y, level}, {_, Y, H}},                // inner walls above the powder
      {0, -1, X, {_, -Y, level}, {_, Y, H}},                 //
      {1, +1, -Y, {-X, _, level}, {X, _, H}},                //
      {1, -1, Y, {-X, _, level}, {X, _, H}},                 //
      {2, +1, H, {-X - w, -Y - w, _}, {-X, Y + w, _}},       // rim
      {2, +1, H, {X, -Y - w, _}, {X + w, Y + w, _}},         //
      {2, +1, H, {-X, -Y - w, _}, {X, -Y, _}},               //
      {2, +1, H, {-X, Y, _}, {X, Y + w, _}},                 //
      {0, -1, -X - w, {_, -Y - w, 0.5 * H}, {_, Y + w, H}},  // outer walls, upper half (the
      {0, +1, X + w, {_, -Y - w, 0.5 * H}, {_, Y + w, H}},   // lower half is near whatever
      {1, -1, -Y - w, {-X - w, _, 0.5 * H}, {X + w, _, H}},  // the box stands on)
      {1, +1, Y + w, {-X - w, _, 0.5 * H}, {X + w, _, H}},   //
  };
}

// The face nearest p among those the camera at `eye` sees the front of, and its distance.
// (Back faces left out: a wall's inner and outer faces are a wall's thickness apart, and a
// scan shifted by that much would otherwise fit too.)
std::pair<const Face*, double> nearestFace(const std::vector<Face>& faces, const Eigen::Vector3d& eye,
                                           const Eigen::Vector3d& p) {
  const Face* best = nullptr;
  double best_d = std::numeric_limits<double>::infinity();
  for (const Face& f : faces) {
    if (f.normal * (eye[f.axis] - f.value) <= 0) continue;
    Eigen::Vector3d q = p.cwiseMax(f.lo).cwiseMin(f.hi);
    q[f.axis] = f.value;
    const double d = (p - q).norm();
    if (d < best_d) best = &f, best_d = d;
  }
  return {best, best_d};
}

// The powder's level at the first guess: the median height of the points over the interior
// (5 cm in from the walls) below the rim.
bool initialLevel(const Cloud& cell_points, const Eigen::Vector3d& size, double& level) {
  std::vector<double> z;
  for (const Point& p : cell_points)
    if (std::abs(p.x()) < 0.5 * size.x() - 0.05 && std::abs(p.y()) < 0.5 * size.y() - 0.05 && p.z() < size.z() - 0.01 &&
        p.z() > -0.05)
      z.push_back(p.z());
  if (z.size() < 10) return false;
  std::nth_element(z.begin(), z.begin() + z.size() / 2, z.end());
  level = z[z.size() / 2];
  return true;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

// Distances of the points within `gate` of the box.
std::vector<double> distances(const Cloud& camera_points, const Pose& T, const std::vector<Face>& faces, double gate) {
  std::vector<double> d;
  for (const Point& q : camera_points) {
    const double di = nearestFace(faces, T.translation(), T * q).second;
    if (di <= gate) d.push_back(di);
  }
  return d;
}

// Whether two frames of one camera can be merged pixel by pixel: the same size and depth unit.
bool sameMode(const DepthImage& a, const DepthImage& b) {
  return a.width == b.width && a.height == b.height && a.depth_unit == b.depth_unit && a.depth.size() == b.depth.size();
}

using Mat7 = Eigen::Matrix<double, 7, 7>;
using Vec7 = Eigen::Matrix<double, 7, 1>;

}  // namespace

DepthImage medianDepth(const std::vector<DepthImage>& frames) {
  if (frames.empty()) return {};
  DepthImage out = frames.front();
  for (const DepthImage& f : frames)
    if (!sameMode(f, out)) return {};
  std::vector<std::uint16_t> v;
  for (std::size_t i = 0; i < out.depth.size(); ++i) {
    v.clear();
    for (const DepthImage& f : frames)
      if (f.depth[i] > 0) v.push_back(f.depth[i]);
    if (2 * v.size() < frames.size()) {
      out.depth[i] = 0;
      continue;
    }
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    out.depth[i] = v[v.size() / 2];
  }
  return out;
}

std::size_t addMedianFrame(std::vector<DepthImage>& frames, DepthImage image) {
  std::size_t dropped = 0;
  if (!frames.empty() && !sameMode(image, frames.front())) {
    dropped = frames.size();
    frames.clear();
  }
  frames.push_back(std::move(image));
  return dropped;
}

BoxCalibration calibrateAgainstBox(const Cloud& camera_points, const Pose& T_initial, const Eigen::Vector3d& box_size,
                                   double wall, const BoxCalibrationConfig& config) {
  BoxCalibration out;
  out.T_cell_camera = T_initial;
  auto fail = [&](const std::string& why) {
    out.ok = false;
    out.problem = why;
    return out;
  };
  if (!isValidPose(T_initial, 1e-4)) return fail("the first guess of T_cell_camera is not a finite rigid transform");
  if (!(box_size.minCoeff() > 0) || !(wall >= 0)) return fail("the box size and wall must be positive");
  if (!initialLevel(transformed(camera_points, T_initial), box_size, out.powder_level))
    return fail(
        "no powder surface in view at the first guess (fewer than 10 points inside the box, 5 cm from its "
        "walls); is the camera looking into the box, and its first guess within a few centimetres?");
  out.median_before =
      median(distances(camera_points, T_initial, boxFaces(box_size, wall, out.powder_level), config.start_gate));

  // Gauss-Newton on x = (turn w about the points' centroid c, shift t, powder level change dh),
  // point to plane: r = p'[axis] - value with p' = R(w) (p - c) + c + t.
  Pose T = T_initial;
  double gate = config.start_gate;
  Mat7 JtJ = Mat7::Zero();
  double sum_r2 = 0;
  std::size_t n = 0, n_powder = 0;
  for (out.iterations = 1; out.iterations <= config.max_iterations; ++out.iterations) {
    const std::vector<Face> faces = boxFaces(box_size, wall, out.powder_level);
    const Cloud p_cell = transformed(camera_points, T);
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (const Point& p : p_cell) c += p;
    c /= std::max<std::size_t>(1, p_cell.size());
    JtJ.setZero();
    Vec7 Jtr = Vec7::Zero();
    sum_r2 = 0;
    n = n_powder = 0;
    const double huber = 0.5 * gate;
    for (const Point& p : p_cell) {
      const auto [face, d] = nearestFace(faces, T.translation(), p);
      if (d > gate) continue;
      const Eigen::Vector3d axis = Eigen::Vector3d::Unit(face->axis);
      const double r = p[face->axis] - face->value;
      Vec7 J;
      J << (p - c).cross(axis), axis, face->powder ? -1.0 : 0.0;
      const double w = std::abs(r) <= huber ? 1.0 : huber / std::abs(r);
      JtJ += w * J * J.transpose();
      Jtr += w * r * J;
      sum_r2 += w * r * r;
      ++n;
      n_powder += face->powder;
    }
    if (n < config.min_points) {
      std::ostringstream s;
      s << "only " << n << " points lie within " << gate * 1000 << " mm of the box (at least " << config.min_points
        << " needed); is the first guess within a few centimetres and degrees?";
      return fail(s.str());
    }
    if (n_powder == 0) JtJ(6, 6) = 1;  // no powder in view: its level stays as it is
    Mat7 A = JtJ;
    A.diagonal() += Vec7::Constant(1e-9 * JtJ.diagonal().maxCoeff());  // a direction not seen stays put
    const Vec7 x = -A.ldlt().solve(Jtr);
    Pose step = Pose::Identity();
    if (x.head<3>().norm() > 0)
      step.linear() = Eigen::AngleAxisd(x.head<3>().norm(), x.head<3>().normalized()).matrix();
    step.translation() = c - step.linear() * c + x.segment<3>(3);
    T = step * T;
    out.powder_level += x(6);
    const bool small = x.segment<3>(3).norm() < 1e-7 && x.head<3>().norm() < 1e-7;
    if (gate <= config.final_gate && small) break;
    gate = std::max(config.final_gate, 0.7 * gate);
  }
  out.T_cell_camera = T;
  out.points = n;
  const std::vector<Face> faces = boxFaces(box_size, wall, out.powder_level);
  out.median_after = median(distances(camera_points, T, faces, config.start_gate));

  // How well the points pin each direction: sigma^2 (J^T J)^-1, the pose block after the level.
  const double sigma2 =
      std::max(sum_r2 / static_cast<double>(std::max<std::size_t>(n, 8) - 7), config.min_noise * config.min_noise);
  Eigen::SelfAdjointEigenSolver<Mat7> eig(JtJ);
  const Vec7 inv =
      eig.eigenvalues().unaryExpr([&](double l) { return l > 1e-12 * eig.eigenvalues().maxCoeff() ? 1.0 / l : 1e30; });
  const Mat7 cov = sigma2 * eig.eigenvectors() * inv.asDiagonal() * eig.eigenvectors().transpose();
  out.sigma_r = cov.diagonal().head<3>().cwiseSqrt();
  out.sigma_t = cov.diagonal().segment<3>(3).cwiseSqrt();
  static const char* kAxes = "xyz";
  for (int k = 0; k < 3; ++k) {
    std::ostringstream s;
    s << std::setprecision(3);
    if (out.sigma_t[k] > config.max_sigma_t)
      s << "the points pin the camera along " << kAxes[k] << " only to +-" << out.sigma_t[k] * 1000 << " mm (at most "
        << config.max_sigma_t * 1000 << ")";
    else if (out.sigma_r[k] * 180 / M_PI > config.max_sigma_r_deg)
      s << "the points pin the camera's turn about " << kAxes[k] << " only to +-" << out.sigma_r[k] * 180 / M_PI
        << " deg (at most " << config.max_sigma_r_deg << ")";
    if (!s.str().empty())
      return fail(s.str() + ": the camera must see the rim and two walls that meet, above a flat powder surface");
  }
  out.ok = true;
  return out;
}

}  // namespace depowder::perception
