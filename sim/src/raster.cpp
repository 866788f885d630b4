#include "depowder/sim/raster.hpp"

#include <algorithm>
#include <cmath>

namespace depowder::sim {
namespace {

// Geometry nearer than this (m, along z) is clipped. Far below the L515's 0.25 m minimum
// range, so a nozzle right in front of the lens still occludes (and returns nothing).
constexpr float kNear = 0.01f;

// Edge functions are evaluated in double; a pixel centre within this (pixel^2) of an edge
// counts as inside, so two triangles sharing an edge never leave a crack between them.
constexpr double kEdgeEps = 1e-7;

}  // namespace

void DepthRasterizer::begin(const CameraModel& camera) {
  width_ = camera.width;
  height_ = camera.height;
  fx_ = static_cast<float>(camera.fx);
  fy_ = static_cast<float>(camera.fy);
  cx_ = static_cast<float>(camera.cx);
  cy_ = static_cast<float>(camera.cy);
  T_camera_cell_ = camera.T_cell_camera.inverse();
  const std::size_t pixels = static_cast<std::size_t>(width_) * height_;
  if (range_per_depth_.size() != pixels || ray_fx_ != camera.fx || ray_fy_ != camera.fy || ray_cx_ != camera.cx ||
      ray_cy_ != camera.cy) {
    range_per_depth_.resize(pixels);
    for (int v = 0; v < height_; ++v)
      for (int u = 0; u < width_; ++u) {
        const double xn = (u - camera.cx) / camera.fx, yn = (v - camera.cy) / camera.fy;
        range_per_depth_[static_cast<std::size_t>(v) * width_ + u] =
            static_cast<float>(std::sqrt(xn * xn + yn * yn + 1));
      }
    ray_fx_ = camera.fx;
    ray_fy_ = camera.fy;
    ray_cx_ = camera.cx;
    ray_cy_ = camera.cy;
  }
  inv_depth_.assign(static_cast<std::size_t>(width_) * height_, 0.0f);
  ids_.resize(inv_depth_.size());
  normals_.clear();
}

void DepthRasterizer::drawMesh(const std::vector<Eigen::Vector3d>& vertices,
                               const std::vector<Eigen::Vector3i>& triangles, const Pose& T_cell_object,
                               Culling culling) {
  const Pose T_camera_object = T_camera_cell_ * T_cell_object;
  scratch_.resize(vertices.size());
  for (std::size_t i = 0; i < vertices.size(); ++i) scratch_[i] = (T_camera_object * vertices[i]).cast<float>();
  // Eigen::Vector3i is three packed ints; signed/unsigned aliasing is allowed.
  static_assert(sizeof(Eigen::Vector3i) == 3 * sizeof(std::uint32_t));
  drawCameraFrame(scratch_, reinterpret_cast<const std::uint32_t*>(triangles.data()), 3 * triangles.size(), culling);
}

void DepthRasterizer::drawCellTriangles(const std::vector<Eigen::Vector3f>& vertices,
                                        const std::vector<std::uint32_t>& indices, Culling culling) {
  const Eigen::Matrix3f R = T_camera_cell_.linear().cast<float>();
  const Eigen::Vector3f t = T_camera_cell_.translation().cast<float>();
  scratch_.resize(vertices.size());
  for (std::size_t i = 0; i < vertices.size(); ++i) scratch_[i] = R * vertices[i] + t;
  drawCameraFrame(scratch_, indices.data(), indices.size(), culling);
}

void DepthRasterizer::drawCameraFrame(const std::vector<Eigen::Vector3f>& cam, const std::uint32_t* indices,
                                      std::size_t count, Culling culling) {
  for (std::size_t k = 0; k + 2 < count; k += 3) {
    const Eigen::Vector3f& a = cam[indices[k]];
    const Eigen::Vector3f& b = cam[indices[k + 1]];
    const Eigen::Vector3f& c = cam[indices[k + 2]];
    const bool in_a = a.z() >= kNear, in_b = b.z() >= kNear, in_c = c.z() >= kNear;
    if (!in_a && !in_b && !in_c) continue;
    const Eigen::Vector3f n = (b - a).cross(c - a);
    // The camera sits at the origin: a front face has its normal against the viewing ray.
    if (culling == Culling::kBackFaces && n.dot(a) >= 0) continue;
    const float len = n.norm();
    if (!(len > 0)) continue;
    const int id = static_cast<int>(normals_.size());
    normals_.push_back(n / len);
    if (in_a && in_b && in_c) {
      const Eigen::Vector3f tri[3] = {a, b, c};
      rasterize(tri, id);
      continue;
    }
    // Sutherland-Hodgman against z = kNear: at most four vertices, drawn as a fan.
    Eigen::Vector3f poly[4];
    int m = 0;
    const Eigen::Vector3f in[3] = {a, b, c};
    for (int i = 0; i < 3; ++i) {
      const Eigen::Vector3f& p = in[i];
      const Eigen::Vector3f& q = in[(i + 1) % 3];
      const bool pin = p.z() >= kNear, qin = q.z() >= kNear;
      if (pin) poly[m++] = p;
      if (pin != qin) {
        const float s = (kNear - p.z()) / (q.z() - p.z());
        poly[m] = p + s * (q - p);
        poly[m++].z() = kNear;
      }
    }
    for (int i = 1; i + 1 < m; ++i) {
      const Eigen::Vector3f tri[3] = {poly[0], poly[i], poly[i + 1]};
      rasterize(tri, id);
    }
  }
}

void DepthRasterizer::rasterize(const Eigen::Vector3f* v, int normal_id) {
  double x[3], y[3], iz[3];
  for (int k = 0; k < 3; ++k) {
    iz[k] = 1.0 / v[k].z();
    x[k] = fx_ * v[k].x() * iz[k] + cx_;
    y[k] = fy_ * v[k].y() * iz[k] + cy_;
  }
  // Pixel (i, j) samples the image at (i, j) (cx = (w - 1) / 2 puts the axis between centres).
  const int x0 = std::max(0, static_cast<int>(std::ceil(std::min({x[0], x[1], x[2]}))));
  const int x1 = std::min(width_ - 1, static_cast<int>(std::floor(std::max({x[0], x[1], x[2]}))));
  const int y0 = std::max(0, static_cast<int>(std::ceil(std::min({y[0], y[1], y[2]}))));
  const int y1 = std::min(height_ - 1, static_cast<int>(std::floor(std::max({y[0], y[1], y[2]}))));
  if (x0 > x1 || y0 > y1) return;
  double area = (x[1] - x[0]) * (y[2] - y[0]) - (y[1] - y[0]) * (x[2] - x[0]);
  if (std::abs(area) < 1e-12) return;
  if (area < 0) {  // make the winding positive (culling was decided already)
    std::swap(x[1], x[2]);
    std::swap(y[1], y[2]);
    std::swap(iz[1], iz[2]);
    area = -area;
  }
  // w_k(p) = edge opposite vertex k; w_k / area are the barycentric coordinates.
  auto edge = [](double ax, double ay, double bx, double by, double px, double py) {
    return (bx - ax) * (py - ay) - (by - ay) * (px - ax);
  };
  const double dx0 = -(y[2] - y[1]), dx1 = -(y[0] - y[2]), dx2 = -(y[1] - y[0]);  // d w / d px
  const double dy0 = x[2] - x[1], dy1 = x[0] - x[2], dy2 = x[1] - x[0];           // d w / d py
  const double inv_area = 1.0 / area;
  const double z0 = iz[0] * inv_area, z1 = iz[1] * inv_area, z2 = iz[2] * inv_area;
  double r0 = edge(x[1], y[1], x[2], y[2], x0, y0);
  double r1 = edge(x[2], y[2], x[0], y[0], x0, y0);
  double r2 = edge(x[0], y[0], x[1], y[1], x0, y0);
  const double ddx[3] = {dx0, dx1, dx2};
  for (int j = y0; j <= y1; ++j, r0 += dy0, r1 += dy1, r2 += dy2) {
    // The row's span where every edge function is >= -kEdgeEps (each is linear in x), widened by
    // a pixel for round-off; the pixels in it are still tested one by one, so the result is the
    // same as testing the whole bounding box, only without visiting the empty part of it.
    double lo = x0, hi = x1;
    const double row[3] = {r0, r1, r2};
    for (int e = 0; e < 3; ++e) {
      if (ddx[e] > 0)
        lo = std::max(lo, x0 + (-kEdgeEps - row[e]) / ddx[e] - 1);
      else if (ddx[e] < 0)
        hi = std::min(hi, x0 + (-kEdgeEps - row[e]) / ddx[e] + 1);
      else if (row[e] < -kEdgeEps)
        hi = lo - 1;  // parallel to this edge and outside it
    }
    if (lo > hi) continue;
    const int i0 = static_cast<int>(std::ceil(lo)), i1 = static_cast<int>(std::floor(hi));
    double w0 = r0 + (i0 - x0) * dx0, w1 = r1 + (i0 - x0) * dx1, w2 = r2 + (i0 - x0) * dx2;
    float* depth_row = inv_depth_.data() + static_cast<std::size_t>(j) * width_;
    std::int32_t* id_row = ids_.data() + static_cast<std::size_t>(j) * width_;
    for (int i = i0; i <= i1; ++i, w0 += dx0, w1 += dx1, w2 += dx2) {
      if (w0 < -kEdgeEps || w1 < -kEdgeEps || w2 < -kEdgeEps) continue;
      const float w = static_cast<float>(w0 * z0 + w1 * z1 + w2 * z2);
      if (w > depth_row[i]) {
        depth_row[i] = w;
        id_row[i] = normal_id;
      }
    }
  }
}

}  // namespace depowder::sim
