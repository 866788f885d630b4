// Procedural generators for the default cell's five parts (see parts.hpp).
//
// Every part is built from closed shells with shared (welded) vertices: surfaces of revolution,
// swept tubes, lofts and boxes. Shells may overlap (a blade poking into the hub), but each one is
// watertight and wound counter-clockwise seen from outside, so volume() is meaningful.
#include "depowder/parts.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <functional>
#include <stdexcept>

namespace depowder::parts {
namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;
using Loop = std::vector<int>;  // vertex indices of a closed loop

constexpr double kPi = 3.14159265358979323846;
constexpr double kCm = 0.01;
constexpr double kDeg = kPi / 180.0;

// ---------------------------------------------------------------------------------------------
// Low-level connectivity. Orientation convention for both helpers: if `a` runs counter-clockwise
// about some axis, band(a, b) faces along (direction of a) x (a -> b), and fan(c, a) faces along
// that axis. Reversing the argument order (band) or the loop (fan) flips the faces.

int addVertex(Mesh& m, const Vector3d& p) {
  m.vertices.push_back(p);
  return static_cast<int>(m.vertices.size()) - 1;
}

Loop addLoop(Mesh& m, const std::vector<Vector3d>& points) {
  Loop loop;
  loop.reserve(points.size());
  for (const auto& p : points) loop.push_back(addVertex(m, p));
  return loop;
}

// Triangles that repeat an index (where a loop collapses to a pole) are skipped, so a "loop" made
// of one vertex repeated closes a band into a fan.
void addTriangle(Mesh& m, int a, int b, int c) {
  if (a == b || b == c || a == c) return;
  m.triangles.emplace_back(a, b, c);
}

void band(Mesh& m, const Loop& a, const Loop& b) {
  const std::size_t n = a.size();
  for (std::size_t j = 0; j < n; ++j) {
    const std::size_t k = (j + 1) % n;
    addTriangle(m, a[j], a[k], b[k]);
    addTriangle(m, a[j], b[k], b[j]);
  }
}

void fan(Mesh& m, int centre, const Loop& loop) { band(m, loop, Loop(loop.size(), centre)); }

Loop reversed(Loop loop) {
  std::reverse(loop.begin(), loop.end());
  return loop;
}

// ---------------------------------------------------------------------------------------------
// Shapes.

/// Surface of revolution about z. `profile` holds (r, z) points running counter-clockwise around
/// the solid's cross-section (material on the left). Either both ends lie on the axis (r == 0;
/// they become single pole vertices) or none does and the profile is a closed loop.
Mesh revolve(const std::vector<Vector2d>& profile, int segments) {
  Mesh m;
  std::vector<Loop> loops;
  for (const auto& rz : profile) {
    if (rz.x() <= 0.0) {
      loops.emplace_back(segments, addVertex(m, Vector3d(0, 0, rz.y())));
      continue;
    }
    std::vector<Vector3d> ring;
    for (int j = 0; j < segments; ++j) {
      const double a = 2 * kPi * j / segments;
      ring.emplace_back(rz.x() * std::cos(a), rz.x() * std::sin(a), rz.y());
    }
    loops.push_back(addLoop(m, ring));
  }
  for (std::size_t i = 0; i + 1 < loops.size(); ++i) band(m, loops[i], loops[i + 1]);
  if (profile.front().x() > 0.0) band(m, loops.back(), loops.front());  // closed loop profile
  return m;
}

/// UV ellipsoid centred at the origin with semi-axes `radii`, then placed by `pose`.
Mesh ellipsoid(const Vector3d& radii, const Pose& pose, int segments, int stacks) {
  std::vector<Vector2d> profile;
  for (int i = 0; i <= stacks; ++i) {
    const double t = kPi * i / stacks;
    profile.emplace_back(i == 0 || i == stacks ? 0.0 : std::sin(t), -std::cos(t));
  }
  Mesh m = revolve(profile, segments);
  for (auto& v : m.vertices) v = pose * radii.cwiseProduct(v);  // positive scale keeps the winding
  return m;
}

}  // namespace

// Faces split into a divisions x divisions grid whose vertices are shared between faces along
// the edges.
Mesh box(const Vector3d& size, int divisions) {
  Mesh m;
  const int n = divisions + 1;
  std::vector<int> index(n * n * n, -1);
  auto vertexAt = [&](Eigen::Vector3i ijk) {
    int& id = index[(ijk[0] * n + ijk[1]) * n + ijk[2]];
    if (id < 0) id = addVertex(m, (ijk.cast<double>() / divisions - Vector3d::Constant(0.5)).cwiseProduct(size));
    return id;
  };
  for (int axis = 0; axis < 3; ++axis) {
    for (int side = 0; side < 2; ++side) {
      // (u, v, axis) right-handed on the + face; swap u and v on the - face so quads face out.
      int u = (axis + 1) % 3, v = (axis + 2) % 3;
      if (side == 0) std::swap(u, v);
      for (int i = 0; i < divisions; ++i) {
        for (int j = 0; j < divisions; ++j) {
          auto at = [&](int di, int dj) {
            Eigen::Vector3i ijk;
            ijk[axis] = side * divisions;
            ijk[u] = i + di;
            ijk[v] = j + dj;
            return vertexAt(ijk);
          };
          addTriangle(m, at(0, 0), at(1, 0), at(1, 1));
          addTriangle(m, at(0, 0), at(1, 1), at(0, 1));
        }
      }
    }
  }
  return m;
}

namespace {

/// A point on a swept path with its rotation-minimising frame: u x v = t.
struct Frame {
  Vector3d p, t, u, v;
};

/// Rotation-minimising frames along a polyline by the double-reflection method (Wang et al.,
/// 2008), so a swept tube does not twist around planar bends or helices.
std::vector<Frame> rotationMinimisingFrames(const std::vector<Vector3d>& path) {
  const std::size_t n = path.size();
  std::vector<Frame> f(n);
  for (std::size_t i = 0; i < n; ++i) {
    // Tangent: the bisector of the adjacent segments, so rings sit symmetric at polyline joints.
    const Vector3d in = i > 0 ? (path[i] - path[i - 1]).normalized() : Vector3d::Zero();
    const Vector3d out = i + 1 < n ? (path[i + 1] - path[i]).normalized() : Vector3d::Zero();
    f[i].p = path[i];
    f[i].t = (in + out).normalized();
  }
  const Vector3d& t0 = f[0].t;
  const Vector3d seed = std::abs(t0.x()) < 0.9 ? Vector3d::UnitX() : Vector3d::UnitY();
  f[0].u = (seed - seed.dot(t0) * t0).normalized();
  f[0].v = t0.cross(f[0].u);
  for (std::size_t i = 0; i + 1 < n; ++i) {
    const Vector3d v1 = f[i + 1].p - f[i].p;
    const double c1 = v1.dot(v1);
    const Vector3d uL = f[i].u - (2 / c1) * v1.dot(f[i].u) * v1;
    const Vector3d tL = f[i].t - (2 / c1) * v1.dot(f[i].t) * v1;
    const Vector3d v2 = f[i + 1].t - tL;
    const double c2 = v2.dot(v2);
    const Vector3d u = c2 > 1e-20 ? Vector3d(uL - (2 / c2) * v2.dot(uL) * v2) : uL;
    f[i + 1].u = (u - u.dot(f[i + 1].t) * f[i + 1].t).normalized();
    f[i + 1].v = f[i + 1].t.cross(f[i + 1].u);
  }
  return f;
}

std::vector<Vector3d> circle(const Frame& f, double radius, int segments) {
  std::vector<Vector3d> ring;
  for (int j = 0; j < segments; ++j) {
    const double a = 2 * kPi * j / segments;
    ring.push_back(f.p + radius * (std::cos(a) * f.u + std::sin(a) * f.v));
  }
  return ring;
}

/// A tube of radius `outer` swept along `path`. With inner == 0 it is solid with flat disc ends;
/// otherwise it is hollow (bore radius `inner`) with annular ends.
Mesh sweepTube(const std::vector<Vector3d>& path, double outer, double inner, int segments) {
  Mesh m;
  const auto frames = rotationMinimisingFrames(path);
  std::vector<Loop> outside, inside;
  for (const auto& f : frames) {
    outside.push_back(addLoop(m, circle(f, outer, segments)));
    if (inner > 0) inside.push_back(addLoop(m, circle(f, inner, segments)));
  }
  for (std::size_t i = 0; i + 1 < frames.size(); ++i) {
    band(m, outside[i], outside[i + 1]);
    if (inner > 0) band(m, inside[i + 1], inside[i]);  // reversed: the bore faces the axis
  }
  if (inner > 0) {
    band(m, inside.front(), outside.front());
    band(m, outside.back(), inside.back());
  } else {
    fan(m, addVertex(m, frames.front().p), reversed(outside.front()));
    fan(m, addVertex(m, frames.back().p), outside.back());
  }
  return m;
}

/// Appends `pieces` evenly spaced points on the segment from the path's last point to `to`.
void lineTo(std::vector<Vector3d>& path, const Vector3d& to, int pieces) {
  const Vector3d from = path.back();
  for (int i = 1; i <= pieces; ++i) path.push_back(from + (to - from) * (double(i) / pieces));
}

/// Appends an arc turning the path's last point by `angle` about the line through `centre`
/// along `axis` (right-hand rule), in `pieces` steps.
void arcAbout(std::vector<Vector3d>& path, const Vector3d& centre, const Vector3d& axis, double angle, int pieces) {
  const Vector3d from = path.back() - centre;
  for (int i = 1; i <= pieces; ++i)
    path.push_back(centre + Eigen::AngleAxisd(angle * i / pieces, axis.normalized()) * from);
}

/// Solid of revolution placed with its z axis along `direction`, its origin at `base`.
Mesh revolvedAlong(const std::vector<Vector2d>& profile, int segments, const Vector3d& base,
                   const Vector3d& direction) {
  Pose pose = Pose::Identity();
  pose.linear() = Eigen::Quaterniond::FromTwoVectors(Vector3d::UnitZ(), direction).toRotationMatrix();
  pose.translation() = base;
  return transformed(revolve(profile, segments), pose);
}

Pose placed(const Vector3d& position, const Eigen::Matrix3d& rotation = Eigen::Matrix3d::Identity()) {
  Pose pose = Pose::Identity();
  pose.linear() = rotation;
  pose.translation() = position;
  return pose;
}

/// Moves the part so its axis-aligned bounding box is centred on the origin (the part frame).
Mesh centred(Mesh m) {
  const Vector3d c = bounds(m).center();
  for (auto& v : m.vertices) v -= c;
  return m;
}

}  // namespace

// ---------------------------------------------------------------------------------------------

Mesh cube() {
  // Faces subdivided so that vertex-based contact models and samplers see more than 8 corners.
  return box(Vector3d::Constant(6 * kCm), 6);
}

Mesh cup() {
  const double R = 3.2 * kCm;  // outer radius
  const double wall = 0.35 * kCm;
  const double floor = 0.5 * kCm;
  const double H = 7.5 * kCm;
  const double fillet = 0.4 * kCm;  // rounded outer bottom edge
  std::vector<Vector2d> profile{{0, 0}};
  for (int i = 0; i <= 4; ++i) {  // quarter circle from the base up to the outer wall
    const double a = -kPi / 2 + kPi / 2 * i / 4;
    profile.emplace_back(R - fillet + fillet * std::cos(a), fillet + fillet * std::sin(a));
  }
  profile.emplace_back(R, H / 2);
  profile.emplace_back(R, H);
  profile.emplace_back(R - wall, H);  // flat rim
  profile.emplace_back(R - wall, H / 2);
  profile.emplace_back(R - wall, floor);
  profile.emplace_back(0, floor);
  Mesh m = revolve(profile, 48);

  // Handle: a D-shaped solid tube in the xz plane on the +x side. Its ends are buried in the
  // wall (centre of the end discs mid-wall) so it fuses with the cup without entering the cavity.
  const double rh = 0.45 * kCm;     // tube radius
  const double reach = 1.75 * kCm;  // centreline distance beyond the outer wall
  const double bend = 1.0 * kCm;    // corner radius of the D
  const double top = 5.8 * kCm, bottom = 1.8 * kCm;
  const Vector3d y = Vector3d::UnitY();
  std::vector<Vector3d> path{{R - wall / 2, 0, top}};
  lineTo(path, {R + reach - bend, 0, top}, 2);
  arcAbout(path, {R + reach - bend, 0, top - bend}, y, kPi / 2, 8);  // about +y turns +x into -z
  lineTo(path, {R + reach, 0, bottom + bend}, 2);
  arcAbout(path, {R + reach - bend, 0, bottom + bend}, y, kPi / 2, 8);
  lineTo(path, {R - wall / 2, 0, bottom}, 2);
  append(m, sweepTube(path, rh, 0.0, 16));
  return centred(m);
}

Mesh propeller() {
  // Hub: a cylinder with a shaft bore and chamfered ends (closed (r, z) loop, counter-clockwise).
  const double hubR = 1.2 * kCm, boreR = 0.3 * kCm, halfH = 1.0 * kCm, ch = 0.15 * kCm;
  Mesh m = revolve({{boreR, -halfH},
                    {hubR - ch, -halfH},
                    {hubR, -halfH + ch},
                    {hubR, halfH - ch},
                    {hubR - ch, halfH},
                    {boreR, halfH}},
                   40);

  // Blades: lofted cambered elliptical sections along the radius. The chord widens then closes
  // to a rounded tip; the pitch falls from root to tip (the twist of a real propeller, constant
  // advance per turn). The root section is buried in the hub.
  const double rootR = 0.9 * kCm, tipR = 5.8 * kCm;
  const int stations = 20, around = 20;
  for (int b = 0; b < 3; ++b) {
    const double azimuth = kPi / 2 + 2 * kPi * b / 3;
    const Vector3d er(std::cos(azimuth), std::sin(azimuth), 0), et(-std::sin(azimuth), std::cos(azimuth), 0);
    const Vector3d ez = Vector3d::UnitZ();  // er x et = ez
    Mesh blade;
    std::vector<Loop> loops;
    for (int k = 0; k < stations; ++k) {
      const double s = double(k) / stations;  // 0 at the root; the tip (s = 1) is a pole below
      const double r = rootR + (tipR - rootR) * s;
      const double round = std::sqrt(1 - std::pow(s, 6));
      const double chord = (1.4 + 1.3 * std::sin(kPi * s)) * kCm * round;
      const double thick = (0.40 * (1 - s) + 0.15 * s) * kCm * std::max(round, 0.3);
      const double pitch = (55 - 35 * s) * kDeg;
      const Vector3d cdir = std::cos(pitch) * et + std::sin(pitch) * ez;   // along the chord
      const Vector3d tdir = -std::sin(pitch) * et + std::cos(pitch) * ez;  // across it; cdir x tdir = er
      std::vector<Vector3d> ring;
      for (int j = 0; j < around; ++j) {
        const double a = 2 * kPi * j / around;
        const double camber = 0.06 * chord * std::sin(a) * std::sin(a);
        ring.push_back(r * er + 0.5 * chord * std::cos(a) * cdir + (0.5 * thick * std::sin(a) + camber) * tdir);
      }
      loops.push_back(addLoop(blade, ring));  // counter-clockwise about er
    }
    fan(blade, addVertex(blade, rootR * er), reversed(loops.front()));
    for (int k = 0; k + 1 < stations; ++k) band(blade, loops[k], loops[k + 1]);
    fan(blade, addVertex(blade, tipR * er), loops.back());
    append(m, blade);
  }
  return centred(m);
}

Mesh owl() {
  // Front is -y. Body: an egg (broad end down) with its bottom cut flat so the owl stands.
  const double eggH = 6.2 * kCm, eggR = 2.6 * kCm, cut = 0.07;
  auto eggRadius = [&](double u) {
    return eggR * std::sqrt(std::max(0.0, 1 - std::pow(2 * u - 1, 2))) * (1.15 - 0.3 * u);
  };
  std::vector<Vector2d> profile{{0, 0}};
  const int steps = 16;
  for (int i = 0; i < steps; ++i) {
    const double u = cut + (1 - cut) * i / steps;
    profile.emplace_back(eggRadius(u), eggH * (u - cut));
  }
  profile.emplace_back(0, eggH * (1 - cut));
  Mesh body = revolve(profile, 32);
  for (auto& v : body.vertices) v.y() *= 0.9;  // owls are a little flatter front to back
  Mesh m = body;

  // Head: a broad ellipsoid sunk into the top of the body (owls have no visible neck).
  append(m, ellipsoid(Vector3d(2.2, 1.9, 1.75) * kCm, placed(Vector3d(0, 0, 6.0) * kCm), 28, 14));

  for (int side = -1; side <= 1; side += 2) {
    const double s = side;
    // Ear tufts: tapered cones leaning outward, bases buried in the head.
    append(m, revolvedAlong({{0, 0}, {0.55 * kCm, 0}, {0.3 * kCm, 0.9 * kCm}, {0, 1.6 * kCm}}, 16,
                            Vector3d(1.1 * s, 0.1, 7.2) * kCm,
                            Vector3d(std::sin(25 * kDeg) * s, 0.1, std::cos(25 * kDeg))));
    // Eyes: flattened discs turned to follow the face, each with a protruding pupil.
    const Eigen::Matrix3d turn = Eigen::AngleAxisd(20 * kDeg * s, Vector3d::UnitZ()).toRotationMatrix();
    const Vector3d eye = Vector3d(0.85 * s, -1.65, 6.3) * kCm;
    append(m, ellipsoid(Vector3d(0.75, 0.3, 0.75) * kCm, placed(eye, turn), 20, 6));
    append(m, ellipsoid(Vector3d::Constant(0.3 * kCm), placed(eye + turn * Vector3d(0, -0.2 * kCm, 0)), 12, 5));
    // Wings: flat ellipsoids on the flanks, tops leaning in.
    const Eigen::Matrix3d lean = Eigen::AngleAxisd(-10 * kDeg * s, Vector3d::UnitY()).toRotationMatrix();
    append(m, ellipsoid(Vector3d(0.55, 1.7, 2.4) * kCm, placed(Vector3d(2.2 * s, 0.3, 2.9) * kCm, lean), 20, 8));
  }
  // Beak: a short cone pointing forward and down from the middle of the face.
  append(m, revolvedAlong({{0, 0}, {0.35 * kCm, 0}, {0, 0.9 * kCm}}, 16, Vector3d(0, -1.6, 5.75) * kCm,
                          Vector3d(0, -0.85, -0.5)));
  return centred(m);
}

Mesh pipe() {
  // Printed upright: a vertical leg opening upward, a 90 degree elbow at the bottom, and a
  // horizontal leg along +x resting on the build plate.
  const double outer = 1.5 * kCm, inner = 1.1 * kCm, bend = 2.5 * kCm;
  const double elbowZ = bend + outer;  // centreline height where the vertical leg meets the elbow
  std::vector<Vector3d> path{{0, 0, 10 * kCm}};
  lineTo(path, {0, 0, elbowZ}, 6);
  arcAbout(path, {bend, 0, elbowZ}, Vector3d::UnitY(), -kPi / 2, 16);  // about -y: heading -z turns to +x
  lineTo(path, {7 * kCm - outer, 0, outer}, 4);
  return centred(sweepTube(path, outer, inner, 24));
}

const std::vector<std::string>& names() {
  static const std::vector<std::string> kNames{"cube", "cup", "propeller", "owl", "pipe"};
  return kNames;
}

Mesh byName(const std::string& name) {
  static const std::vector<std::pair<std::string, std::function<Mesh()>>> kMakers{
      {"cube", cube}, {"cup", cup}, {"propeller", propeller}, {"owl", owl}, {"pipe", pipe}};
  for (const auto& [n, make] : kMakers)
    if (n == name) return make();
  std::string known;
  for (const auto& n : names()) known += (known.empty() ? "" : ", ") + n;
  throw std::invalid_argument("unknown part '" + name + "' (known parts: " + known + ")");
}

}  // namespace depowder::parts
