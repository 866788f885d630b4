#include "depowder/tracker/sight.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace depowder::tracker {

namespace {
constexpr float kEmpty = std::numeric_limits<float>::infinity();
constexpr int kMaxSide = 512;
constexpr double kMinCosine = 0.5;  // a point is judged from cameras within 60 deg of its normal  // pixels; a region
                                    // seen from closer than its size is clipped to this
}  // namespace

// Pixel of p in a gnomonic (pinhole) projection along the image's axis, or -1 outside.
int SightImages::Image::pixelOf(const Point& p, double* range_out) const {
  const Eigen::Vector3d d = p - eye;
  const double along = d.dot(axis);
  if (!(along > 1e-6)) return -1;
  const int x = static_cast<int>(std::floor((d.dot(u) / along - x0) / pixel));
  const int y = static_cast<int>(std::floor((d.dot(v) / along - y0) / pixel));
  if (x < 0 || y < 0 || x >= width || y >= height) return -1;
  *range_out = d.norm();
  return y * width + x;
}

SightImages::SightImages(const Cloud& scan, const std::vector<Point>& viewpoints, const Eigen::AlignedBox3d& region,
                         double pixel) {
  if (region.isEmpty() || !(pixel > 0)) return;
  for (const Point& eye : viewpoints) {
    Image im;
    im.eye = eye;
    im.pixel = pixel;
    im.axis = (region.center() - eye).normalized();
    if (!im.axis.allFinite()) continue;  // a camera inside the region sees nothing useful here
    const Eigen::Vector3d a = std::abs(im.axis.z()) < 0.9 ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d::UnitX();
    im.u = im.axis.cross(a).normalized();
    im.v = im.axis.cross(im.u);
    // The image spans the region's corners as seen from the eye.
    double x_min = INFINITY, x_max = -INFINITY, y_min = INFINITY, y_max = -INFINITY;
    bool ok = true;
    for (int c = 0; c < 8; ++c) {
      const Eigen::Vector3d d = region.corner(static_cast<Eigen::AlignedBox3d::CornerType>(c)) - eye;
      const double along = d.dot(im.axis);
      if (along <= 1e-3) ok = false;
      const double x = d.dot(im.u) / along, y = d.dot(im.v) / along;
      x_min = std::min(x_min, x), x_max = std::max(x_max, x), y_min = std::min(y_min, y), y_max = std::max(y_max, y);
    }
    if (!ok) continue;
    im.x0 = x_min, im.y0 = y_min;
    im.width = std::clamp(static_cast<int>(std::ceil((x_max - x_min) / pixel)), 1, kMaxSide);
    im.height = std::clamp(static_cast<int>(std::ceil((y_max - y_min) / pixel)), 1, kMaxSide);
    im.range.assign(static_cast<std::size_t>(im.width) * im.height, kEmpty);
    for (const Point& p : scan) {
      double r;
      const int k = im.pixelOf(p, &r);
      if (k >= 0) im.range[k] = std::min(im.range[k], static_cast<float>(r));
    }
    images_.push_back(std::move(im));
  }
}

SightCheck SightImages::check(const Cloud& points, const Cloud& normals, double tolerance,
                              std::vector<unsigned char>* verdict) const {
  SightCheck c;
  if (verdict) verdict->assign(points.size(), 0);
  for (std::size_t i = 0; i < points.size(); ++i) {
    bool seen = false, in_front = false, hidden = false;
    for (const Image& im : images_) {
      const Eigen::Vector3d to_eye = im.eye - points[i];
      // Judged only where it faces the camera clearly: at a grazing angle the point lies on the
      // silhouette, whose pixels mix the part with what is behind it.
      if (normals[i].dot(to_eye) <= kMinCosine * to_eye.norm()) continue;
      double r;
      const int k = im.pixelOf(points[i], &r);
      if (k < 0) continue;
      // The scanned range in the pixel and its 8 neighbours (one pixel of slack for the voxels'
      // spacing and the projection): the point is in front only if it is in front of all of them.
      const int x = k % im.width, y = k / im.width;
      double nearest = INFINITY;
      bool on_surface = false;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int xx = x + dx, yy = y + dy;
          if (xx < 0 || yy < 0 || xx >= im.width || yy >= im.height) continue;
          const float s = im.range[static_cast<std::size_t>(yy) * im.width + xx];
          nearest = std::min(nearest, static_cast<double>(s));
          if (std::abs(r - s) <= tolerance) on_surface = true;
        }
      if (nearest == kEmpty) continue;  // no scan along this line of sight
      if (on_surface)
        seen = true;
      else if (r < nearest - tolerance)
        in_front = true;
      else
        hidden = true;
    }
    SightCheck::Verdict v = SightCheck::kUnknown;
    if (seen)
      v = SightCheck::kSeen, ++c.seen;
    else if (in_front)
      v = SightCheck::kInFront, ++c.in_front;
    else if (hidden)
      v = SightCheck::kHidden, ++c.hidden;
    else
      ++c.unknown;
    if (verdict) (*verdict)[i] = v;
  }
  return c;
}

}  // namespace depowder::tracker
