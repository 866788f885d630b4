#include "depowder/planner/paths.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "axis_distance.hpp"

namespace depowder::planner {

const char* toString(PathStatus s) {
  switch (s) {
    case PathStatus::kOk:
      return "OK";
    case PathStatus::kInvalidPose:
      return "INVALID_POSE";
    case PathStatus::kInvalidHeight:
      return "INVALID_HEIGHT";
    case PathStatus::kEmptyContour:
      return "EMPTY_CONTOUR";
    case PathStatus::kInvalidContour:
      return "INVALID_CONTOUR";
    case PathStatus::kNoPath:
      return "NO_PATH";
  }
  return "?";
}

const char* toString(LoopSource s) { return s == LoopSource::kContour ? "contour" : "footprint"; }

namespace {

using V2 = Eigen::Vector2d;
using Loop2 = std::vector<V2>;
constexpr double kPi = 3.14159265358979323846;

double cross(const V2& a, const V2& b) { return a.x() * b.y() - a.y() * b.x(); }

double signedArea(const Loop2& p) {
  double a = 0;
  for (std::size_t i = 0; i < p.size(); ++i) a += cross(p[i], p[(i + 1) % p.size()]);
  return 0.5 * a;
}

/// Crossing-number point-in-polygon test.
bool inside(const Loop2& poly, const V2& q) {
  bool in = false;
  for (std::size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    const V2& a = poly[i];
    const V2& b = poly[j];
    if ((a.y() > q.y()) != (b.y() > q.y()) && q.x() < (b.x() - a.x()) * (q.y() - a.y()) / (b.y() - a.y()) + a.x())
      in = !in;
  }
  return in;
}

/// Andrew's monotone chain; counter-clockwise, no repeated first point.
Loop2 convexHull(Loop2 pts) {
  std::sort(pts.begin(), pts.end(),
            [](const V2& a, const V2& b) { return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y()); });
  if (pts.size() < 3) return pts;
  Loop2 hull(2 * pts.size());
  std::size_t k = 0;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    while (k >= 2 && cross(hull[k - 1] - hull[k - 2], pts[i] - hull[k - 2]) <= 0) --k;
    hull[k++] = pts[i];
  }
  for (std::size_t i = pts.size() - 1, t = k + 1; i > 0; --i) {
    while (k >= t && cross(hull[k - 1] - hull[k - 2], pts[i - 1] - hull[k - 2]) <= 0) --k;
    hull[k++] = pts[i - 1];
  }
  hull.resize(k - 1);
  return hull;
}

/// Points `spacing` apart (or a little less) along the closed polyline.
Loop2 resampleClosed(const Loop2& loop, double spacing) {
  const std::size_t n = loop.size();
  std::vector<double> s(n + 1, 0.0);
  for (std::size_t i = 0; i < n; ++i) s[i + 1] = s[i] + (loop[(i + 1) % n] - loop[i]).norm();
  const double length = s[n];
  if (length <= 0) return {};
  const int count = std::max(8, static_cast<int>(std::ceil(length / spacing)));
  Loop2 out;
  out.reserve(count);
  std::size_t seg = 0;
  for (int k = 0; k < count; ++k) {
    const double at = length * k / count;
    while (seg + 1 < n && s[seg + 1] <= at) ++seg;
    const double len = s[seg + 1] - s[seg];
    const double f = len > 0 ? (at - s[seg]) / len : 0.0;
    out.push_back(loop[seg] + f * (loop[(seg + 1) % n] - loop[seg]));
  }
  return out;
}

/// Drops the points where a counter-clockwise loop runs backwards around `centre` (folds made
/// where neighbouring points were pushed across each other in a concave corner). Starts at the
/// point farthest from the centre, which lies on the outer loop.
Loop2 removeFolds(const Loop2& loop, const V2& centre) {
  if (loop.size() < 3) return loop;
  std::size_t start = 0;
  for (std::size_t i = 1; i < loop.size(); ++i)
    if ((loop[i] - centre).squaredNorm() > (loop[start] - centre).squaredNorm()) start = i;
  Loop2 out{loop[start]};
  double travelled = 0;
  for (std::size_t k = 1; k < loop.size(); ++k) {
    const V2& p = loop[(start + k) % loop.size()];
    const V2 a = out.back() - centre;
    const V2 b = p - centre;
    const double turn = std::atan2(cross(a, b), a.dot(b));
    if (turn <= 0 || travelled + turn >= 2 * kPi - 1e-9) continue;
    travelled += turn;
    out.push_back(p);
  }
  return out;
}

/// Moves points in xy until the nozzle axis (tip at eval_z, reaching axis_length up) is
/// `standoff` from the part. Each point moves along one horizontal ray (away from its nearest
/// part point), bracketing the stand-off and closing in by regula falsi (Illinois), so it
/// converges where plain Newton steps would oscillate on sloped surfaces; when the iterations
/// run out it keeps the bracket end on the safe (outer) side.
struct Pusher {
  const AxisDistanceField& field;
  double eval_z;
  double axis_length;
  double standoff;
  double tolerance;
  V2 centre;

  double distanceAt(const V2& p, AxisDistanceField::Result* out = nullptr) {
    const auto d = field.query(p.x(), p.y(), eval_z, eval_z + axis_length, 3 * standoff);
    if (out) *out = d;
    return d.distance;
  }

  /// Returns the final distance.
  double push(V2& p, int max_iterations) {
    AxisDistanceField::Result d;
    const double f0 = distanceAt(p, &d) - standoff;
    if (std::abs(f0) <= tolerance) return d.distance;
    V2 dir = p - centre;
    dir = dir.norm() > 1e-9 ? V2(dir.normalized()) : V2(1, 0);
    double step = standoff;  // the axis touches the part: go straight out
    if (d.cut_off) {
      step = -f0;  // far away: head straight in
    } else if (d.distance > 1e-6) {
      const Point v = d.on_axis - d.on_part;
      const V2 h(v.x(), v.y());
      double cosine = 1;
      if (h.norm() > 1e-9) {
        dir = h.normalized();
        cosine = std::max(0.2, h.norm() / v.norm());
      }
      step = std::clamp(-f0 / cosine, -standoff, standoff);
    }
    const V2 p0 = p;
    auto f = [&](double t) { return distanceAt(p0 + t * dir) - standoff; };
    double ta = 0, fa = f0, tb = step, fb = f(step);
    for (int k = 0; k < 4 && (fa < 0) == (fb < 0); ++k) {
      ta = tb;
      fa = fb;
      tb += step;
      fb = f(tb);
    }
    if ((fa < 0) == (fb < 0)) {  // no bracket: keep the better end
      p = p0 + (std::abs(fa) < std::abs(fb) ? ta : tb) * dir;
      return (std::abs(fa) < std::abs(fb) ? fa : fb) + standoff;
    }
    for (int it = 0; it < max_iterations; ++it) {
      const double t = (ta * fb - tb * fa) / (fb - fa);
      const double ft = f(t);
      if (std::abs(ft) <= tolerance) {
        p = p0 + t * dir;
        return ft + standoff;
      }
      if ((ft < 0) != (fb < 0)) {
        ta = tb;
        fa = fb;
      } else {
        fa *= 0.5;
      }
      tb = t;
      fb = ft;
    }
    // Out of iterations: the end on the outer side (fa's sign holds; Illinois may have halved
    // its value, so the distance there is measured again).
    const bool a_outside = fa > 0;
    p = p0 + (a_outside ? ta : tb) * dir;
    return a_outside ? distanceAt(p) : fb + standoff;
  }
};

Eigen::AlignedBox3d posedBounds(const PartShape& part, const Pose& T) {
  Eigen::AlignedBox3d b;
  for (const auto& v : part.mesh().vertices) b.extend(T * v);
  return b;
}

/// The part's vertices at or above z_low, projected to xy (all of them if none is).
Loop2 bandPoints(const PartShape& part, const Pose& T, double z_low) {
  Loop2 band, all;
  for (const auto& v : part.mesh().vertices) {
    const Point p = T * v;
    all.emplace_back(p.x(), p.y());
    if (p.z() >= z_low) band.emplace_back(p.x(), p.y());
  }
  return band.size() >= 3 ? band : all;
}

V2 bandCentre(const PartShape& part, const Pose& T, double z_low) {
  const Loop2 band = bandPoints(part, T, z_low);
  V2 c = V2::Zero();
  for (const V2& p : band) c += p;
  return c / static_cast<double>(band.size());
}

/// Centroid of the area enclosed by a simple polygon (vertex mean if degenerate).
V2 areaCentroid(const Loop2& p) {
  double a = 0;
  V2 c = V2::Zero();
  for (std::size_t i = 0; i < p.size(); ++i) {
    const V2& u = p[i];
    const V2& v = p[(i + 1) % p.size()];
    const double w = cross(u, v);
    a += w;
    c += w * (u + v);
  }
  if (std::abs(a) < 1e-12) {
    c = V2::Zero();
    for (const V2& u : p) c += u;
    return c / static_cast<double>(p.size());
  }
  return c / (3 * a);
}

/// Shared tail of both loop builders: push a counter-clockwise seed out to the stand-off,
/// clean folds, resample, push again, then order it for the nozzle.
LoopResult finishLoop(const PartShape& part, const Pose& T_cell_part, Loop2 seed, double height, double eval_z,
                      const V2& centre, const Point& nozzle_now, const PlannerConfig& config, LoopSource source) {
  const VacuumConfig& vc = config.vacuum;
  LoopResult r;
  r.source = source;
  r.height = height;
  const double top = std::max(height, eval_z) + config.nozzle.length;
  const AxisDistanceField field(part.mesh(), T_cell_part);
  Pusher pusher{field, eval_z, top - eval_z, vc.standoff, vc.standoff_tolerance, centre};

  // Push, drop folds, resample (twice: the second pass fixes the spacing the first changed),
  // then a last push that also measures every waypoint's stand-off.
  Loop2 pts = resampleClosed(seed, vc.spacing);
  for (int pass = 0; pass < 2 && pts.size() >= 3; ++pass) {
    for (V2& p : pts) pusher.push(p, pass == 0 ? 6 : 4);
    pts = removeFolds(pts, centre);
    if (pts.size() >= 3) pts = resampleClosed(pts, vc.spacing);
  }
  std::vector<double> distance(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) distance[i] = pusher.push(pts[i], 4);
  if (pts.size() < 3) {
    r.status = PathStatus::kNoPath;
    r.reason = "the loop collapsed to " + std::to_string(pts.size()) + " points";
    return r;
  }
  r.min_standoff = *std::min_element(distance.begin(), distance.end());
  r.max_standoff = *std::max_element(distance.begin(), distance.end());

  // Order: start nearest the nozzle, run in the configured direction, close the loop.
  std::size_t start = 0;
  const V2 now(nozzle_now.x(), nozzle_now.y());
  for (std::size_t i = 1; i < pts.size(); ++i)
    if ((pts[i] - now).squaredNorm() < (pts[start] - now).squaredNorm()) start = i;
  std::rotate(pts.begin(), pts.begin() + static_cast<std::ptrdiff_t>(start), pts.end());
  if (!vc.counter_clockwise) std::reverse(pts.begin() + 1, pts.end());
  r.tips.reserve(pts.size() + 1);
  for (const V2& p : pts) r.tips.emplace_back(p.x(), p.y(), height);
  r.tips.push_back(r.tips.front());
  r.status = PathStatus::kOk;
  return r;
}

/// Height at which the stand-off is measured: the tip height, but never above the part's
/// top (while the powder still covers the part the loop runs around where the part is).
double evalHeight(const HeightRange& hr, double height) { return std::min(height, hr.max - 1e-3); }

}  // namespace

HeightRange partHeights(const PartShape& part, const Pose& T_cell_part) {
  const Eigen::AlignedBox3d b = posedBounds(part, T_cell_part);
  return {b.min().z(), b.max().z()};
}

double loopFloor(const PartShape& part, const Pose& T_cell_part, const VacuumConfig& config) {
  return std::max(partHeights(part, T_cell_part).min - config.undercut, config.min_tip_height);
}

double loopHeight(const PartShape& part, const Pose& T_cell_part, double powder_height, const VacuumConfig& config) {
  return std::max(powder_height - config.layer_depth, loopFloor(part, T_cell_part, config));
}

namespace {

// A loop's inputs every source shares: a rigid pose and a finite powder height. False, with the
// status and reason in r, otherwise.
bool validLoopInput(const PartShape& part, const Pose& T_cell_part, double powder_height, LoopResult& r) {
  if (!isValidPose(T_cell_part, 1e-6)) {
    r.status = PathStatus::kInvalidPose;
    r.reason = "the pose of '" + part.name() + "' is not a valid rigid transform";
    return false;
  }
  if (!std::isfinite(powder_height)) {
    r.status = PathStatus::kInvalidHeight;
    r.reason = "the powder height is not finite";
    return false;
  }
  return true;
}

}  // namespace

LoopResult contourLoop(const PartShape& part, const Pose& T_cell_part, const Cloud& contour, double powder_height,
                       const Point& nozzle_now, const PlannerConfig& config) {
  LoopResult r;
  r.source = LoopSource::kContour;
  if (!validLoopInput(part, T_cell_part, powder_height, r)) return r;
  if (contour.empty()) {
    r.status = PathStatus::kEmptyContour;
    r.reason = "the contour of '" + part.name() + "' is empty";
    return r;
  }
  Loop2 seed;
  seed.reserve(contour.size());
  for (const Point& p : contour) {
    if (!p.allFinite()) {
      r.status = PathStatus::kInvalidContour;
      r.reason = "the contour of '" + part.name() + "' has a non-finite point";
      return r;
    }
    seed.emplace_back(p.x(), p.y());
  }
  if (static_cast<int>(seed.size()) < config.vacuum.min_contour_points) {
    r.status = PathStatus::kInvalidContour;
    r.reason = "the contour of '" + part.name() + "' has " + std::to_string(seed.size()) + " points, fewer than " +
               std::to_string(config.vacuum.min_contour_points);
    return r;
  }
  const HeightRange hr = partHeights(part, T_cell_part);
  const double height = loopHeight(part, T_cell_part, powder_height, config.vacuum);
  const double eval_z = evalHeight(hr, height);
  if (!inside(seed, bandCentre(part, T_cell_part, eval_z - config.vacuum.standoff))) {
    r.status = PathStatus::kInvalidContour;
    r.reason = "the contour of '" + part.name() + "' does not enclose the part";
    return r;
  }
  if (signedArea(seed) < 0) std::reverse(seed.begin(), seed.end());
  const V2 centre = areaCentroid(seed);
  return finishLoop(part, T_cell_part, std::move(seed), height, eval_z, centre, nozzle_now, config,
                    LoopSource::kContour);
}

LoopResult footprintLoop(const PartShape& part, const Pose& T_cell_part, double powder_height, const Point& nozzle_now,
                         const PlannerConfig& config) {
  LoopResult r;
  r.source = LoopSource::kFootprint;
  if (!validLoopInput(part, T_cell_part, powder_height, r)) return r;
  const HeightRange hr = partHeights(part, T_cell_part);
  const double height = loopHeight(part, T_cell_part, powder_height, config.vacuum);
  const double eval_z = evalHeight(hr, height);
  const double s = config.vacuum.standoff;
  // The footprint of the part the nozzle can reach: vertices above eval_z - s.
  const Loop2 hull = convexHull(bandPoints(part, T_cell_part, eval_z - s));
  if (hull.size() < 3) {
    r.status = PathStatus::kNoPath;
    r.reason = "the footprint of '" + part.name() + "' is degenerate";
    return r;
  }
  // Grow the hull by s: each edge moved out along its normal, joined by arcs at the vertices.
  Loop2 seed;
  const std::size_t n = hull.size();
  for (std::size_t i = 0; i < n; ++i) {
    const V2& prev = hull[(i + n - 1) % n];
    const V2& cur = hull[i];
    const V2& next = hull[(i + 1) % n];
    const V2 e0 = (cur - prev).normalized();
    const V2 e1 = (next - cur).normalized();
    const double a0 = std::atan2(-e0.x(), e0.y());  // outward normal of a ccw edge: (e.y, -e.x)
    double a1 = std::atan2(-e1.x(), e1.y());
    while (a1 < a0) a1 += 2 * kPi;
    const int steps = std::max(1, static_cast<int>(std::ceil((a1 - a0) * s / config.vacuum.spacing)));
    for (int k = 0; k <= steps; ++k) {
      const double a = a0 + (a1 - a0) * k / steps;
      const V2 normal(std::cos(a), std::sin(a));
      seed.push_back(cur + s * normal);
    }
  }
  const V2 centre = areaCentroid(hull);
  return finishLoop(part, T_cell_part, std::move(seed), height, eval_z, centre, nozzle_now, config,
                    LoopSource::kFootprint);
}

RasterResult blastRaster(const PartShape& part, const Pose& T_cell_part, const Point& nozzle_now,
                         const PlannerConfig& config) {
  RasterResult r;
  if (!isValidPose(T_cell_part, 1e-6)) {
    r.status = PathStatus::kInvalidPose;
    r.reason = "the pose of '" + part.name() + "' is not a valid rigid transform";
    return r;
  }
  const BlastConfig& bc = config.blast;
  const Mesh posed = transformed(part.mesh(), T_cell_part);
  // Reach of the nozzle: the tip rises `standoff` above every part point within this radius.
  const double reach = config.nozzle.radius + config.nozzle.margin + config.collision.tracking_margin + bc.overhang;
  // Height map, conservative: every cell a triangle's xy bounding box touches holds at least
  // that triangle's highest vertex (no part point in a cell is higher than its value).
  const double cell = 0.004;
  Eigen::AlignedBox2d box;
  for (const Point& v : posed.vertices) box.extend(v.head<2>());
  const V2 origin = box.min() - V2::Constant(reach + cell);
  const int nx = static_cast<int>(std::ceil((box.sizes().x() + 2 * (reach + cell)) / cell)) + 1;
  const int ny = static_cast<int>(std::ceil((box.sizes().y() + 2 * (reach + cell)) / cell)) + 1;
  const double kNone = -std::numeric_limits<double>::infinity();
  std::vector<double> top(static_cast<std::size_t>(nx) * ny, kNone);
  for (const auto& t : posed.triangles) {
    Eigen::AlignedBox3d tb;
    for (int k = 0; k < 3; ++k) tb.extend(posed.vertices[t[k]]);
    const int x0 = static_cast<int>((tb.min().x() - origin.x()) / cell);
    const int x1 = static_cast<int>((tb.max().x() - origin.x()) / cell);
    const int y0 = static_cast<int>((tb.min().y() - origin.y()) / cell);
    const int y1 = static_cast<int>((tb.max().y() - origin.y()) / cell);
    for (int iy = y0; iy <= y1; ++iy)
      for (int ix = x0; ix <= x1; ++ix) {
        double& h = top[static_cast<std::size_t>(iy) * nx + ix];
        h = std::max(h, tb.max().z());
      }
  }
  // Highest point within `reach` of (x, y) (cells whose nearest corner is within reach + a cell).
  const int rc = static_cast<int>(std::ceil(reach / cell)) + 1;
  auto topNear = [&](const V2& q) {
    const int cx = static_cast<int>((q.x() - origin.x()) / cell);
    const int cy = static_cast<int>((q.y() - origin.y()) / cell);
    double best = kNone;
    for (int iy = std::max(0, cy - rc); iy <= std::min(ny - 1, cy + rc); ++iy)
      for (int ix = std::max(0, cx - rc); ix <= std::min(nx - 1, cx + rc); ++ix) {
        const double t = top[static_cast<std::size_t>(iy) * nx + ix];
        if (t == kNone) continue;
        const V2 c = origin + V2((ix + 0.5) * cell, (iy + 0.5) * cell);
        if ((c - q).norm() <= reach + cell) best = std::max(best, t);
      }
    return best;
  };

  const V2 lo = box.min() - V2::Constant(bc.overhang);
  const V2 hi = box.max() + V2::Constant(bc.overhang);
  const int rows = std::max(1, static_cast<int>(std::ceil((hi.y() - lo.y()) / bc.spacing))) + 1;
  const int cols = std::max(1, static_cast<int>(std::ceil((hi.x() - lo.x()) / bc.step))) + 1;
  // Start at the corner nearest the nozzle: flip the row order and/or the first direction.
  const bool from_top = std::abs(nozzle_now.y() - hi.y()) < std::abs(nozzle_now.y() - lo.y());
  bool leftward = std::abs(nozzle_now.x() - hi.x()) < std::abs(nozzle_now.x() - lo.x());
  for (int k = 0; k < rows; ++k) {
    const int row = from_top ? rows - 1 - k : k;
    const double y = rows == 1 ? 0.5 * (lo.y() + hi.y()) : lo.y() + (hi.y() - lo.y()) * row / (rows - 1);
    Cloud line;
    for (int j = 0; j < cols; ++j) {
      const double x = lo.x() + (hi.x() - lo.x()) * j / (cols - 1);
      const double t = topNear(V2(x, y));
      if (t == kNone) continue;  // beyond the footprint
      line.emplace_back(x, y, t + bc.standoff);
    }
    if (line.empty()) continue;
    if (leftward) std::reverse(line.begin(), line.end());
    leftward = !leftward;
    r.tips.insert(r.tips.end(), line.begin(), line.end());
    ++r.lines;
  }
  if (r.tips.empty()) {
    r.status = PathStatus::kNoPath;
    r.reason = "the raster over '" + part.name() + "' is empty";
    return r;
  }
  r.status = PathStatus::kOk;
  return r;
}

}  // namespace depowder::planner
