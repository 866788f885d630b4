#include "depowder/perception/depth.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace depowder::perception {

namespace {

FrameError fail(FrameStatus status, const std::string& camera, const std::string& what) {
  return {status, "camera '" + camera + "': " + what};
}

// Pose and range limits: what both depth images and recorded scans need.
FrameError checkPoseAndRange(const PinholeCamera& camera) {
  if (!isValidPose(camera.T_cell_camera, 1e-4))
    return fail(FrameStatus::kBadHeader, camera.name, "T_cell_camera is not a finite rigid transform");
  if (!std::isfinite(camera.min_range) || !std::isfinite(camera.max_range) || camera.min_range < 0 ||
      camera.max_range <= camera.min_range) {
    std::ostringstream s;
    s << "range limits [" << camera.min_range << ", " << camera.max_range << "] m are invalid";
    return fail(FrameStatus::kBadHeader, camera.name, s.str());
  }
  return {};
}

// A depth count from a real one, clamped to [lo, hi] before the cast: casting a double beyond
// long's range (a header's extreme but finite unit or intrinsics) or NaN is undefined.
long countIn(double c, long lo, long hi) { return c >= lo ? (c <= hi ? static_cast<long>(c) : hi) : lo; }

bool inside(const Eigen::AlignedBox3d& box, const Eigen::Vector3d& p) {
  return (p.array() >= box.min().array()).all() && (p.array() <= box.max().array()).all();
}

}  // namespace

Eigen::AlignedBox3d cropBox(const Eigen::Vector3d& box_size, double margin) {
  const Eigen::Vector3d m = Eigen::Vector3d::Constant(margin);
  return {Eigen::Vector3d(-0.5 * box_size.x(), -0.5 * box_size.y(), 0.0) - m,
          Eigen::Vector3d(0.5 * box_size.x(), 0.5 * box_size.y(), box_size.z()) + m};
}

FrameError checkDepthImage(const DepthImage& image, const PinholeCamera& camera) {
  if (image.width <= 0 || image.height <= 0) {
    std::ostringstream s;
    s << "frame " << image.frame << " has an impossible size " << image.width << "x" << image.height;
    return fail(FrameStatus::kBadHeader, camera.name, s.str());
  }
  const std::size_t expected = static_cast<std::size_t>(image.width) * static_cast<std::size_t>(image.height);
  if (image.depth.size() != expected) {
    std::ostringstream s;
    s << "frame " << image.frame << " carries " << image.depth.size() << " depth pixels but its header says "
      << image.width << "x" << image.height << " = " << expected;
    return fail(FrameStatus::kSizeMismatch, camera.name, s.str());
  }
  if (camera.width > 0 && (camera.width != image.width || camera.height != image.height)) {
    std::ostringstream s;
    s << "frame " << image.frame << " is " << image.width << "x" << image.height << " but the camera is "
      << camera.width << "x" << camera.height;
    return fail(FrameStatus::kSizeMismatch, camera.name, s.str());
  }
  const Eigen::Vector4d k(camera.fx, camera.fy, camera.cx, camera.cy);
  if (!k.allFinite() || camera.fx <= 0 || camera.fy <= 0)
    return fail(FrameStatus::kBadHeader, camera.name, "intrinsics (fx, fy, cx, cy) are not finite and positive");
  // Every pixel's ray within 89.9 deg of the optical axis: finite, tiny fx or far cx gave rays of
  // inf or NaN, and the Deprojector's range search then stepped through 65535 counts a pixel.
  constexpr double kMaxSlope = 1000;
  for (const double slope : {camera.cx / camera.fx, (image.width - 1 - camera.cx) / camera.fx, camera.cy / camera.fy,
                             (image.height - 1 - camera.cy) / camera.fy})
    if (!(std::abs(slope) <= kMaxSlope))
      return fail(FrameStatus::kBadHeader, camera.name,
                  "intrinsics (fx, fy, cx, cy) put a corner pixel's ray more than 89.9 deg off the optical axis");
  if (!std::isfinite(image.depth_unit) || image.depth_unit <= 0)
    return fail(FrameStatus::kBadHeader, camera.name, "depth_unit must be a finite positive number of metres");
  return checkPoseAndRange(camera);
}

CameraCloud deproject(const DepthImage& image, const PinholeCamera& camera, const Eigen::AlignedBox3d& crop) {
  CameraCloud out;
  out.error = checkDepthImage(image, camera);
  if (!out.error.ok()) return out;
  const int w = image.width, h = image.height;
  // p_cell = t + z * R * [(u - cx) / fx, (v - cy) / fy, 1]: the bracket splits into a
  // per-column and a per-row term, so a pixel costs three multiply-adds.
  const Eigen::Matrix3d& R = camera.T_cell_camera.linear();
  const Eigen::Vector3d t = camera.T_cell_camera.translation();
  std::vector<Eigen::Vector3d> column(static_cast<std::size_t>(w)), row(static_cast<std::size_t>(h));
  for (int u = 0; u < w; ++u) column[u] = R.col(0) * ((u - camera.cx) / camera.fx);
  for (int v = 0; v < h; ++v) row[v] = R.col(1) * ((v - camera.cy) / camera.fy) + R.col(2);
  // Range limits on the distance from the camera centre (the ray length a LiDAR such as the
  // L515 measures): |p_camera| = z * |ray| with ray = [(u - cx) / fx, (v - cy) / fy, 1], and
  // |R ray| = |ray|. Compared squared, so a pixel needs no square root.
  const double unit = image.depth_unit;
  const double min2 = camera.min_range * camera.min_range, max2 = camera.max_range * camera.max_range;

  FrameCounts& n = out.counts;
  n.inputs = image.depth.size();
  out.points.reserve(n.inputs / 2);
  const std::uint16_t* d = image.depth.data();
  for (int v = 0; v < h; ++v) {
    const Eigen::Vector3d& rv = row[v];
    for (int u = 0; u < w; ++u, ++d) {
      const std::uint32_t raw = *d;
      if (raw == 0) {
        ++n.no_return;
        continue;
      }
      const double z = raw * unit;
      const Eigen::Vector3d ray = column[u] + rv;
      const double range2 = z * z * ray.squaredNorm();
      if (range2 < min2 || range2 > max2) {
        ++n.out_of_range;
        continue;
      }
      const Eigen::Vector3d p = t + z * ray;
      if (!inside(crop, p)) {
        ++n.outside_crop;
        continue;
      }
      out.points.push_back(p);
    }
  }
  n.kept = out.points.size();
  if (n.kept + n.outside_crop == 0) {
    std::ostringstream s;
    s << "frame " << image.frame << " has no valid return (" << n.no_return << " of " << n.inputs << " pixels empty, "
      << n.out_of_range << " out of range)";
    out.error = fail(FrameStatus::kNoValidReturns, camera.name, s.str());
  }
  return out;
}

bool Deprojector::current(const DepthImage& image, const PinholeCamera& camera) const {
  const PinholeCamera& c = camera_;
  return !limits_.empty() && image.depth_unit == unit_ && camera.width == c.width && camera.height == c.height &&
         image.width == c.width && image.height == c.height && camera.fx == c.fx && camera.fy == c.fy &&
         camera.cx == c.cx && camera.cy == c.cy && camera.min_range == c.min_range && camera.max_range == c.max_range &&
         camera.T_cell_camera.matrix() == c.T_cell_camera.matrix();
}

void Deprojector::build(const DepthImage& image, const PinholeCamera& camera) {
  ++rebuilds_;
  camera_ = camera;
  camera_.width = image.width;
  camera_.height = image.height;
  unit_ = image.depth_unit;
  const int w = image.width, h = image.height;
  const Eigen::Matrix3d& R = camera.T_cell_camera.linear();
  const Eigen::Vector3d t = camera.T_cell_camera.translation();
  // The same per-column / per-row terms as deproject(), so the same arithmetic decides.
  column_.resize(static_cast<std::size_t>(w));
  row_.resize(static_cast<std::size_t>(h));
  for (int u = 0; u < w; ++u) column_[u] = R.col(0) * ((u - camera.cx) / camera.fx);
  for (int v = 0; v < h; ++v) row_[v] = R.col(1) * ((v - camera.cy) / camera.fy) + R.col(2);
  const double unit = unit_;
  const double min2 = camera.min_range * camera.min_range, max2 = camera.max_range * camera.max_range;
  limits_.resize(static_cast<std::size_t>(w) * h);
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      const Eigen::Vector3d ray = column_[u] + row_[v];
      const double n2 = ray.squaredNorm();
      // Range: the first and last count that deproject()'s test accepts (it is monotonic in
      // the count); start from the closed form and step to the exact boundary.
      auto above_min = [&](long c) {
        const double z = static_cast<double>(c) * unit;
        return !(z * z * n2 < min2);
      };
      auto below_max = [&](long c) {
        const double z = static_cast<double>(c) * unit;
        return !(z * z * n2 > max2);
      };
      const double norm = std::sqrt(n2);
      long lo = countIn(std::ceil(camera.min_range / (unit * norm)), 1, 65536);
      while (lo > 1 && above_min(lo - 1)) --lo;
      while (lo <= 65535 && !above_min(lo)) ++lo;
      long hi = countIn(std::floor(camera.max_range / (unit * norm)), 0, 65535);
      while (hi < 65535 && below_max(hi + 1)) ++hi;
      while (hi >= 1 && !below_max(hi)) --hi;
      // Crop: the depths at which t + z ray is inside the box (slab method), widened by a count.
      double z0 = 0, z1 = std::numeric_limits<double>::infinity();
      for (int k = 0; k < 3; ++k) {
        if (std::abs(ray[k]) < 1e-12) {
          if (t[k] < crop_.min()[k] || t[k] > crop_.max()[k]) z1 = -1;
          continue;
        }
        const double a = (crop_.min()[k] - t[k]) / ray[k], b = (crop_.max()[k] - t[k]) / ray[k];
        z0 = std::max(z0, std::min(a, b));
        z1 = std::min(z1, std::max(a, b));
      }
      long clo = 1, chi = 0;  // empty
      if (z1 >= z0) {
        clo = countIn(std::floor(z0 / unit) - 1, 1, 65535);
        chi = countIn(std::ceil(z1 / unit) + 1, 0, 65535);
      }
      Limits& L = limits_[static_cast<std::size_t>(v) * w + u];
      L.range_lo = static_cast<std::uint16_t>(std::min(lo, 65535L));
      L.range_hi = static_cast<std::uint16_t>(lo > 65535 ? 0 : hi);
      L.crop_lo = static_cast<std::uint16_t>(clo);
      L.crop_hi = static_cast<std::uint16_t>(chi);
      if (lo > hi) {  // nothing in range: make the range test reject every count
        L.range_lo = 65535;
        L.range_hi = 0;
      }
    }
}

CameraCloud Deprojector::operator()(const DepthImage& image, const PinholeCamera& camera, Cloud&& storage) {
  CameraCloud out;
  out.points = std::move(storage);  // reused capacity: no fresh pages to fault in every frame
  out.points.clear();
  out.error = checkDepthImage(image, camera);
  if (!out.error.ok()) return out;
  if (!current(image, camera)) build(image, camera);
  const int w = image.width, h = image.height;
  const double unit = unit_;
  const Eigen::Vector3d t = camera_.T_cell_camera.translation();
  FrameCounts& n = out.counts;
  n.inputs = image.depth.size();
  const std::uint16_t* d = image.depth.data();
  const Limits* L = limits_.data();
  for (int v = 0; v < h; ++v) {
    const Eigen::Vector3d& rv = row_[v];
    for (int u = 0; u < w; ++u, ++d, ++L) {
      const std::uint16_t raw = *d;
      if (raw == 0) {
        ++n.no_return;
      } else if (raw < L->range_lo || raw > L->range_hi) {
        ++n.out_of_range;
      } else if (raw < L->crop_lo || raw > L->crop_hi) {
        ++n.outside_crop;
      } else {
        const Eigen::Vector3d p = t + (raw * unit) * (column_[u] + rv);
        if (inside(crop_, p))
          out.points.push_back(p);
        else
          ++n.outside_crop;
      }
    }
  }
  n.kept = out.points.size();
  if (n.kept + n.outside_crop == 0) {
    std::ostringstream s;
    s << "frame " << image.frame << " has no valid return (" << n.no_return << " of " << n.inputs << " pixels empty, "
      << n.out_of_range << " out of range)";
    out.error = fail(FrameStatus::kNoValidReturns, camera.name, s.str());
  }
  return out;
}

CameraCloud cameraPointsToCell(const Cloud& camera_points, const PinholeCamera& camera,
                               const Eigen::AlignedBox3d& crop) {
  CameraCloud out;
  out.error = checkPoseAndRange(camera);
  if (!out.error.ok()) return out;
  FrameCounts& n = out.counts;
  n.inputs = camera_points.size();
  out.points.reserve(n.inputs / 2);
  for (const Eigen::Vector3d& q : camera_points) {
    if (!q.allFinite()) {
      ++n.no_return;
      continue;
    }
    const double range = q.norm();
    if (range < camera.min_range || range > camera.max_range) {
      ++n.out_of_range;
      continue;
    }
    const Eigen::Vector3d p = camera.T_cell_camera * q;
    if (!inside(crop, p)) {
      ++n.outside_crop;
      continue;
    }
    out.points.push_back(p);
  }
  n.kept = out.points.size();
  if (n.kept + n.outside_crop == 0) {
    std::ostringstream s;
    s << "scan has no valid point (" << n.no_return << " of " << n.inputs << " NaN or infinite, " << n.out_of_range
      << " out of range)";
    out.error = fail(FrameStatus::kNoValidReturns, camera.name, s.str());
  }
  return out;
}

}  // namespace depowder::perception
