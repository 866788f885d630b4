#include "depowder/sim/world.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "depowder/sim/noise.hpp"

namespace depowder::sim {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// An axis-aligned rectangle centred at c, facing along axis `normal_axis` (0, 1, 2) with
// sign `sign`, half-extents h (the entry along the normal is ignored), wound to face out.
void addRect(Mesh& m, const Eigen::Vector3d& c, int normal_axis, int sign, const Eigen::Vector3d& h) {
  // (u, v) such that u x v is the normal: x y -> z, y z -> x, z x -> y; swapped for a negative sign.
  int a = (normal_axis + 1) % 3, b = (normal_axis + 2) % 3;
  if (sign < 0) std::swap(a, b);
  Eigen::Vector3d u = Eigen::Vector3d::Zero(), v = Eigen::Vector3d::Zero();
  u[a] = h[a];
  v[b] = h[b];
  const int base = static_cast<int>(m.vertices.size());
  m.vertices.push_back(c - u - v);
  m.vertices.push_back(c + u - v);
  m.vertices.push_back(c + u + v);
  m.vertices.push_back(c - u + v);
  m.triangles.emplace_back(base, base + 1, base + 2);
  m.triangles.emplace_back(base, base + 2, base + 3);
}

// The build box: floor, inner and outer walls and the rim, as seen from outside the solid.
Mesh boxMesh(const BoxGeometry& box) {
  const double X = 0.5 * box.size.x(), Y = 0.5 * box.size.y(), H = box.size.z(), w = box.wall;
  Mesh m;
  addRect(m, {0, 0, 0}, 2, +1, {X, Y, 0});  // floor
  addRect(m, {-X, 0, H / 2}, 0, +1, {0, Y, H / 2});
  addRect(m, {X, 0, H / 2}, 0, -1, {0, Y, H / 2});
  addRect(m, {0, -Y, H / 2}, 1, +1, {X, 0, H / 2});
  addRect(m, {0, Y, H / 2}, 1, -1, {X, 0, H / 2});
  if (w > 0) {
    const double zc = 0.5 * (H - w), hz = 0.5 * (H + w);  // outer walls from the table (z = -w) to the rim
    addRect(m, {-X - w, 0, zc}, 0, -1, {0, Y + w, hz});
    addRect(m, {X + w, 0, zc}, 0, +1, {0, Y + w, hz});
    addRect(m, {0, -Y - w, zc}, 1, -1, {X + w, 0, hz});
    addRect(m, {0, Y + w, zc}, 1, +1, {X + w, 0, hz});
    addRect(m, {-X - w / 2, 0, H}, 2, +1, {w / 2, Y + w, 0});  // rim
    addRect(m, {X + w / 2, 0, H}, 2, +1, {w / 2, Y + w, 0});
    addRect(m, {0, -Y - w / 2, H}, 2, +1, {X, w / 2, 0});
    addRect(m, {0, Y + w / 2, H}, 2, +1, {X, w / 2, 0});
  }
  return m;
}

// Per powder cell of the window [i0, i1] x [j0, j1]: -1 inside the footprint (cells with a finite
// `top`, and the holes they enclose), else the distance (m) to the footprint's edge, measured
// between cell centres less half a cell (the edge lies about half a cell beyond the last covered
// centre). Cells off the window get +inf.
std::vector<double> footprintDistance(const PowderField& f, const std::vector<double>& top, int i0, int i1, int j0,
                                      int j1) {
  const int nx = f.nx();
  std::vector<double> dist(f.size(), kInf);
  const int wi = i1 - i0 + 1, wj = j1 - j0 + 1;
  if (wi <= 0 || wj <= 0) return dist;
  auto local = [&](int i, int j) { return static_cast<std::size_t>(j - j0) * wi + (i - i0); };
  // 0 = unknown, 1 = footprint, 2 = reachable from the window's border without crossing the footprint.
  std::vector<std::uint8_t> mark(static_cast<std::size_t>(wi) * wj, 0);
  for (int j = j0; j <= j1; ++j)
    for (int i = i0; i <= i1; ++i)
      if (std::isfinite(top[static_cast<std::size_t>(j) * nx + i])) mark[local(i, j)] = 1;
  std::vector<std::pair<int, int>> stack;
  for (int j = j0; j <= j1; ++j)
    for (int i = i0; i <= i1; ++i)
      if ((i == i0 || i == i1 || j == j0 || j == j1) && mark[local(i, j)] == 0) {
        mark[local(i, j)] = 2;
        stack.emplace_back(i, j);
      }
  while (!stack.empty()) {
    const auto [i, j] = stack.back();
    stack.pop_back();
    const int di[4] = {1, -1, 0, 0}, dj[4] = {0, 0, 1, -1};
    for (int k = 0; k < 4; ++k) {
      const int a = i + di[k], b = j + dj[k];
      if (a < i0 || a > i1 || b < j0 || b > j1 || mark[local(a, b)] != 0) continue;
      mark[local(a, b)] = 2;
      stack.emplace_back(a, b);
    }
  }
  // Edge cells of the filled footprint (those with an outside 4-neighbour).
  std::vector<Eigen::Vector2d> edge;
  for (int j = j0; j <= j1; ++j)
    for (int i = i0; i <= i1; ++i) {
      if (mark[local(i, j)] == 2) continue;
      dist[f.index(i, j)] = -1;
      const bool outer = (i > i0 && mark[local(i - 1, j)] == 2) || (i < i1 && mark[local(i + 1, j)] == 2) ||
                         (j > j0 && mark[local(i, j - 1)] == 2) || (j < j1 && mark[local(i, j + 1)] == 2);
      if (outer) edge.push_back(f.centre(i, j));
    }
  if (edge.empty()) return dist;
  const double half = 0.25 * (f.dx() + f.dy());
  for (int j = j0; j <= j1; ++j)
    for (int i = i0; i <= i1; ++i) {
      if (mark[local(i, j)] != 2) continue;
      const Eigen::Vector2d p = f.centre(i, j);
      double best = kInf;
      for (const auto& e : edge) best = std::min(best, (e - p).squaredNorm());
      dist[f.index(i, j)] = std::max(0.0, std::sqrt(best) - half);
    }
  return dist;
}

}  // namespace

World::World(const SimConfig& config, const BoxGeometry& box, std::vector<PartSpec> parts,
             std::vector<CameraModel> cameras, std::uint32_t seed)
    : config_(config),
      box_(box),
      powder_(box.size.x(), box.size.y(), config.powder.cell_size),
      cameras_(std::move(cameras)) {
  if (!(box.size.minCoeff() > 0)) throw std::invalid_argument("World: the box size must be positive");
  for (auto& spec : parts) {
    if (spec.mesh.triangles.empty()) throw std::invalid_argument("World: part '" + spec.name + "' has no triangles");
    // The powder's support, the contacts and the mass need the part's inside.
    if (const std::string problem = solidProblem(spec.mesh); !problem.empty())
      throw std::invalid_argument("World: part '" + spec.name + "' is " + problem);
    for (const auto& p : parts_)
      if (p.spec.name == spec.name) throw std::invalid_argument("World: part name '" + spec.name + "' is used twice");
    PartState s;
    s.solid = PartSolid(spec.mesh, config_.scene.solid_column);
    s.T_last = spec.T_cell_part;
    s.spec = std::move(spec);
    updatePartGeometry(s);
    parts_.push_back(std::move(s));
  }
  updateFloor();
  double level = config_.powder.level;
  if (level < 0) {
    double top = 0;
    for (const auto& p : parts_) top = std::max(top, p.h_max);
    level = top + config_.powder.cover;
  }
  powder_.fill(std::min(level, box_.size.z()));

  for (std::size_t i = 0; i < cameras_.size(); ++i) {
    std::seed_seq seq{seed, static_cast<std::uint32_t>(i), 0x5EEDu};
    rngs_.emplace_back(seq);
  }
  frames_.assign(cameras_.size(), 0);
  rasterizers_.resize(cameras_.size());

  box_mesh_ = boxMesh(box_);
  if (config_.scene.table_size > 0)
    addRect(table_mesh_, {0, 0, -box_.wall}, 2, +1, Eigen::Vector3d::Constant(0.5 * config_.scene.table_size));
  nozzle_mesh_ = cylinderMesh(config_.nozzle.radius, config_.nozzle.length, config_.nozzle.segments);
  nozzle_samples_ = contactSamples(nozzle_mesh_, config_.scene.contact_spacing);

  if (config_.physics.enabled) {
    std::vector<PartSpec> specs;
    std::vector<const PartSolid*> solids;
    for (const auto& p : parts_) {
      specs.push_back(p.spec);
      solids.push_back(&p.solid);
    }
    physics_ = std::make_unique<Physics>(config_.physics, box_, specs, solids);
    physics_->setNozzleMesh(nozzle_mesh_);
  }
}

std::size_t World::partIndex(const std::string& name) const {
  std::string known;
  for (std::size_t i = 0; i < parts_.size(); ++i) {
    if (parts_[i].spec.name == name) return i;
    known += (known.empty() ? "" : ", ") + parts_[i].spec.name;
  }
  throw std::invalid_argument("no part '" + name + "' in the world (parts: " + known + ")");
}

void World::updatePartGeometry(PartState& p) {
  const Pose& T = p.spec.T_cell_part;
  p.T_geometry = T;
  std::vector<Eigen::Vector3d> posed(p.spec.mesh.vertices.size());
  p.h_max = -kInf;
  p.h_min = kInf;
  for (std::size_t k = 0; k < posed.size(); ++k) {
    posed[k] = T * p.spec.mesh.vertices[k];
    p.h_max = std::max(p.h_max, posed[k].z());
    p.h_min = std::min(p.h_min, posed[k].z());
  }
  ColumnGrid grid;
  grid.dx = powder_.dx();
  grid.dy = powder_.dy();
  grid.x0 = powder_.centre(0, 0).x();
  grid.y0 = powder_.centre(0, 0).y();
  grid.nx = powder_.nx();
  grid.ny = powder_.ny();
  meshEnvelope(posed, p.spec.mesh.triangles, grid, p.top, p.bottom);

  // The Eq. 2 band: cells in [band_inner, band_outer) from the footprint.
  p.band.clear();
  int i0 = powder_.nx(), i1 = -1, j0 = powder_.ny(), j1 = -1;
  for (int j = 0; j < powder_.ny(); ++j)
    for (int i = 0; i < powder_.nx(); ++i)
      if (std::isfinite(p.top[powder_.index(i, j)])) {
        i0 = std::min(i0, i);
        i1 = std::max(i1, i);
        j0 = std::min(j0, j);
        j1 = std::max(j1, j);
      }
  p.fi0 = i0;
  p.fi1 = i1;
  p.fj0 = j0;
  p.fj1 = j1;
  if (i1 < 0) return;  // not over the box
  const int margin = static_cast<int>(std::ceil(config_.truth.band_outer / std::min(powder_.dx(), powder_.dy()))) + 2;
  const std::vector<double> dist =
      footprintDistance(powder_, p.top, std::max(0, i0 - margin), std::min(powder_.nx() - 1, i1 + margin),
                        std::max(0, j0 - margin), std::min(powder_.ny() - 1, j1 + margin));
  for (std::size_t c = 0; c < dist.size(); ++c)
    if (dist[c] >= config_.truth.band_inner && dist[c] < config_.truth.band_outer) p.band.push_back(c);
}

void World::updateFloor() {
  std::vector<double> floor(powder_.size(), 0.0);
  std::vector<std::uint8_t> over(powder_.size(), 0);
  for (const auto& p : parts_)
    for (std::size_t c = 0; c < floor.size(); ++c)
      if (std::isfinite(p.top[c])) {
        over[c] = 1;
        floor[c] = std::max(floor[c], p.top[c]);
      }
  powder_.setFloor(floor, over);
}

void World::setNozzle(const Pose& T_cell_nozzle, Tool tool) {
  T_cell_nozzle_ = T_cell_nozzle;
  tool_ = tool;
  nozzle_present_ = true;
}

void World::removeNozzle() {
  nozzle_present_ = false;
  tool_ = Tool::kOff;
}

void World::setNozzleMesh(Mesh mesh, bool closed_outward) {
  nozzle_mesh_ = std::move(mesh);
  nozzle_closed_ = closed_outward;
  nozzle_samples_ = contactSamples(nozzle_mesh_, config_.scene.contact_spacing);
  if (physics_) physics_->setNozzleMesh(nozzle_mesh_);
}

void World::setArmLinks(std::vector<Mesh> link_meshes) {
  link_meshes_ = std::move(link_meshes);
  if (physics_) physics_->setArmLinks(link_meshes_);
  link_samples_.clear();
  for (const auto& m : link_meshes_) link_samples_.push_back(contactSamples(m, config_.scene.contact_spacing));
  T_cell_links_.clear();
}

void World::setArmLinkPoses(const std::vector<Pose>& T_cell_link) {
  if (T_cell_link.size() != link_meshes_.size())
    throw std::invalid_argument("World::setArmLinkPoses: " + std::to_string(T_cell_link.size()) + " poses for " +
                                std::to_string(link_meshes_.size()) + " links");
  T_cell_links_ = T_cell_link;
}

void World::setArm(const ArmState& arm) {
  if (arm.nozzle_present)
    setNozzle(arm.T_cell_nozzle, arm.tool);
  else
    removeNozzle();
  if (!arm.T_cell_links.empty()) setArmLinkPoses(arm.T_cell_links);
}

void World::setPartPose(std::size_t part, const Pose& T_cell_part) {
  PartState& p = parts_.at(part);
  p.spec.T_cell_part = T_cell_part;
  updatePartGeometry(p);
  updateFloor();
  if (physics_) physics_->teleport(part, T_cell_part);
}

void World::step(double dt) {
  powder_.beginStep();
  advanceParts(dt);
  if (nozzle_present_) {
    const Eigen::Vector3d tip = T_cell_nozzle_.translation();
    if (tool_ == Tool::kVacuum) removed_ += powder_.vacuum(tip, config_.vacuum, dt);
    if (tool_ == Tool::kAir) removed_ += powder_.airBlast(tip, config_.air, dt);
  }
  powder_.relax(config_.powder.repose_deg, config_.powder.relax_sweeps, config_.powder.relax_tolerance);
  updateContacts();
  for (auto& p : parts_) {
    p.speed = dt > 0 ? translationDistance(p.spec.T_cell_part, p.T_last) / dt : 0.0;
    p.angular_speed = dt > 0 ? rotationAngle(p.T_last.linear(), p.spec.T_cell_part.linear()) / dt : 0.0;
    p.T_last = p.spec.T_cell_part;
  }
  time_ += dt;
  ++steps_;
}

void World::updateContacts() {
  for (std::size_t i = 0; i < parts_.size(); ++i) {
    PartState& p = parts_[i];
    const Pose T_part_cell = p.spec.T_cell_part.inverse();
    bool contact = false;
    auto test = [&](const Cloud& samples, const Pose& T_cell_object) {
      const Pose T_part_object = T_part_cell * T_cell_object;
      for (const auto& s : samples)
        if (p.solid.contains(T_part_object * s)) return true;
      return false;
    };
    if (nozzle_present_) contact = test(nozzle_samples_, T_cell_nozzle_);
    for (std::size_t k = 0; !contact && k < T_cell_links_.size(); ++k)
      contact = test(link_samples_[k], T_cell_links_[k]);
    // With physics the nozzle pushes instead of entering: touching counts.
    if (!contact && physics_) contact = physics_->touching(i);
    if (contact && !p.contact) ++contact_count_;
    p.contact = contact;
  }
}

void World::setPowderLevel(double level) { powder_.fill(std::min(level, box_.size.z())); }

void World::digToVisibility(std::size_t part, double eta) {
  digAround(part, eta, std::max(powder_.nx(), powder_.ny()));
}

void World::digAround(std::size_t part, double eta, int margin) {
  const PartState& p = parts_.at(part);
  eta = std::clamp(eta, 0.0, 1.0);
  const double level = p.h_max - eta * (p.h_max - p.h_min);
  const std::vector<double> dist =
      footprintDistance(powder_, p.top, std::max(0, p.fi0 - margin), std::min(powder_.nx() - 1, p.fi1 + margin),
                        std::max(0, p.fj0 - margin), std::min(powder_.ny() - 1, p.fj1 + margin));
  // Flat to a little beyond the band, then up at 2 deg under the angle of repose (stable).
  const double flat = config_.truth.band_outer + 2 * std::max(powder_.dx(), powder_.dy());
  const double slope = std::tan((std::max(1.0, config_.powder.repose_deg - 2.0)) * M_PI / 180.0);
  for (std::size_t c = 0; c < powder_.size(); ++c) {
    const double allowed = level + slope * std::max(0.0, dist[c] - flat);
    if (powder_.height(c) > allowed) powder_.setHeight(c, allowed);
  }
}

void World::buildPowderMesh() {
  if (powder_mesh_version_ == powder_.version()) return;
  powder_mesh_version_ = powder_.version();
  const int nx = powder_.nx(), ny = powder_.ny(), VX = nx + 2, VY = ny + 2;
  // Vertices at the cell centres, plus a ring on the walls that repeats the edge cells.
  std::vector<float> xs(VX), ys(VY);
  xs[0] = static_cast<float>(-0.5 * box_.size.x());
  xs[VX - 1] = static_cast<float>(0.5 * box_.size.x());
  for (int i = 0; i < nx; ++i) xs[i + 1] = static_cast<float>(powder_.centre(i, 0).x());
  ys[0] = static_cast<float>(-0.5 * box_.size.y());
  ys[VY - 1] = static_cast<float>(0.5 * box_.size.y());
  for (int j = 0; j < ny; ++j) ys[j + 1] = static_cast<float>(powder_.centre(0, j).y());
  powder_vertices_.resize(static_cast<std::size_t>(VX) * VY);
  std::vector<std::uint8_t> bare(powder_vertices_.size());
  const double thin = config_.powder.bare_thickness;
  for (int b = 0; b < VY; ++b)
    for (int a = 0; a < VX; ++a) {
      const std::size_t c = powder_.index(std::clamp(a - 1, 0, nx - 1), std::clamp(b - 1, 0, ny - 1));
      const std::size_t v = static_cast<std::size_t>(b) * VX + a;
      powder_vertices_[v] = Eigen::Vector3f(xs[a], ys[b], static_cast<float>(powder_.height(c)));
      bare[v] = powder_.height(c) - powder_.floor(c) < thin;
    }
  // Two triangles a quad, counter-clockwise from above; a triangle with no powder at any corner is
  // left out, so bare parts and the bare floor show their own surfaces.
  powder_indices_.clear();
  for (int b = 0; b + 1 < VY; ++b)
    for (int a = 0; a + 1 < VX; ++a) {
      const std::uint32_t v00 = b * VX + a, v10 = v00 + 1, v01 = v00 + VX, v11 = v01 + 1;
      if (!(bare[v00] && bare[v10] && bare[v11])) powder_indices_.insert(powder_indices_.end(), {v00, v10, v11});
      if (!(bare[v00] && bare[v11] && bare[v01])) powder_indices_.insert(powder_indices_.end(), {v00, v11, v01});
    }
}

DepthImage World::render(std::size_t camera) { return render(camera, &rngs_.at(camera)); }

DepthImage World::render(std::size_t camera, std::mt19937* rng) {
  const CameraModel& cam = cameras_.at(camera);
  DepthRasterizer& r = rasterizers_[camera];
  r.begin(cam);
  if (!table_mesh_.triangles.empty())
    r.drawMesh(table_mesh_.vertices, table_mesh_.triangles, Pose::Identity(), Culling::kBackFaces);
  r.drawMesh(box_mesh_.vertices, box_mesh_.triangles, Pose::Identity(), Culling::kBackFaces);
  buildPowderMesh();
  r.drawCellTriangles(powder_vertices_, powder_indices_, Culling::kBackFaces);
  // Part meshes come from anywhere: drawn two-sided so a wrong winding cannot open holes.
  for (const auto& p : parts_)
    r.drawMesh(p.spec.mesh.vertices, p.spec.mesh.triangles, p.spec.T_cell_part, Culling::kNone);
  if (nozzle_present_)
    r.drawMesh(nozzle_mesh_.vertices, nozzle_mesh_.triangles, T_cell_nozzle_,
               nozzle_closed_ ? Culling::kBackFaces : Culling::kNone);
  for (std::size_t k = 0; k < T_cell_links_.size(); ++k)
    r.drawMesh(link_meshes_[k].vertices, link_meshes_[k].triangles, T_cell_links_[k], Culling::kNone);
  DepthImage out;
  makeDepthImage(r, cam, config_.scene.depth_unit, rng, out);
  out.frame = frames_[camera]++;
  out.time = time_;
  return out;
}

PartTruth World::partTruth(std::size_t part) const {
  const PartState& p = parts_.at(part);
  PartTruth t;
  t.name = p.spec.name;
  t.T_cell_part = p.spec.T_cell_part;
  t.h_max = p.h_max;
  t.h_min = p.h_min;
  t.nozzle_contact = p.contact;
  t.speed = p.speed;
  t.angular_speed = p.angular_speed;
  // Eq. 2 with H_pow the mean surface height of the band; cells over any part are not powder beside it.
  double sum = 0;
  for (std::size_t c : p.band)
    if (!powder_.overPart(c)) {
      sum += powder_.height(c);
      ++t.band_cells;
    }
  if (t.band_cells > 0 && p.h_max > p.h_min) {
    t.h_pow = sum / t.band_cells;
    t.eta = std::clamp((p.h_max - std::min(t.h_pow, p.h_max)) / (p.h_max - p.h_min), 0.0, 1.0);
  }
  return t;
}

Truth World::truth() const {
  Truth t;
  t.time = time_;
  for (std::size_t i = 0; i < parts_.size(); ++i) t.parts.push_back(partTruth(i));
  t.T_cell_nozzle = T_cell_nozzle_;
  t.tool = nozzle_present_ ? tool_ : Tool::kOff;
  t.powder_removed_m3 = removed_;
  t.powder_volume_m3 = powder_.volume();
  t.contact_count = contact_count_;
  return t;
}

double World::powderInBox() const {
  double sum = 0;
  for (std::size_t c = 0; c < powder_.size(); ++c) {
    const double h = powder_.height(c);
    double occ = 0;
    for (const auto& p : parts_)
      if (std::isfinite(p.top[c]) && h > std::max(0.0, p.bottom[c]))
        occ += std::min(p.top[c], h) - std::max(0.0, p.bottom[c]);
    sum += std::max(0.0, h - occ);
  }
  return sum * powder_.cellArea();
}

void World::movePart(std::size_t part, const Pose& T_cell_part) {
  std::vector<Pose> poses;
  for (const auto& p : parts_) poses.push_back(p.spec.T_cell_part);
  poses.at(part) = T_cell_part;
  std::vector<bool> displace(parts_.size(), false);
  displace[part] = true;
  moveParts(poses, displace);
  if (physics_) physics_->teleport(part, T_cell_part);
}

void World::setPartMotion(std::size_t part, const Motion& motion) {
  if (part >= parts_.size())
    throw std::invalid_argument("World::setPartMotion: no part " + std::to_string(part) + " (the cell has " +
                                std::to_string(parts_.size()) + ")");
  PartState& p = parts_[part];
  const auto refuse = [&](const std::string& what) {
    throw std::invalid_argument("World::setPartMotion: part '" + p.spec.name + "': " + what);
  };
  if (!motion.velocity.allFinite()) refuse("the velocity is not finite");
  if (!std::isfinite(motion.rate)) refuse("the turntable rate is not finite");
  if (motion.centre && !motion.centre->allFinite()) refuse("the turntable centre is not finite");
  if (!std::isfinite(motion.start)) refuse("the start is not finite");
  if (!(motion.duration >= 0)) refuse("the duration is negative or NaN");  // infinity: until cleared
  PartState::Scripted s;
  s.motion = motion;
  s.motion.start = std::max(motion.start, time_);
  s.T_start = p.spec.T_cell_part;
  if (motion.centre) {
    s.centre = *motion.centre;
  } else {
    Eigen::AlignedBox3d b;
    for (const auto& v : p.spec.mesh.vertices) b.extend(p.spec.T_cell_part * v);
    s.centre = b.center().head<2>();
  }
  p.motion = s;
  if (physics_) physics_->setScripted(part, true);
}

void World::clearPartMotion(std::size_t part) {
  parts_.at(part).motion.reset();
  if (physics_) physics_->setScripted(part, false);
}

void World::advanceParts(double dt) {
  const double t_end = time_ + dt;
  std::vector<std::optional<Pose>> targets(parts_.size());
  bool scripted = false;
  for (std::size_t i = 0; i < parts_.size(); ++i)
    if (const auto& m = parts_[i].motion) {
      targets[i] = motionPose(m->motion, m->T_start, m->centre, t_end);
      scripted = true;
    }
  if (!physics_ && !scripted) return;

  // 1. Where the parts go: scripted ones on their paths, the others where the physics takes them.
  std::vector<Pose> poses(parts_.size());
  if (physics_) {
    Physics::StepInput in;
    in.nozzle_present = nozzle_present_;
    in.T_cell_nozzle = T_cell_nozzle_;
    in.T_cell_links = T_cell_links_;
    in.targets = targets;
    in.powder = &powder_;
    in.repose_deg = config_.powder.repose_deg;
    in.covered = [this](std::size_t part, std::size_t cell) { return std::isfinite(parts_[part].top[cell]); };
    physics_->step(dt, in);
  }
  std::vector<bool> displace(parts_.size());
  for (std::size_t i = 0; i < parts_.size(); ++i) {
    poses[i] = targets[i] ? *targets[i] : physics_ ? physics_->pose(i) : parts_[i].spec.T_cell_part;
    const auto& m = parts_[i].motion;
    displace[i] = m ? m->motion.visibility < 0 : config_.physics.powder.displace;
  }

  // 2. Move them (the powder is pushed aside), then keep the set visibilities (the crater follows).
  moveParts(poses, displace);
  const double cell = std::min(powder_.dx(), powder_.dy());
  const int margin = static_cast<int>(std::ceil((config_.truth.band_outer + 0.03) / cell)) + 2;
  for (std::size_t i = 0; i < parts_.size(); ++i) {
    const auto& m = parts_[i].motion;
    if (m && m->motion.visibility >= 0) digAround(i, m->motion.visibility, margin);
  }

  // 3. Motions that ended release their parts.
  for (std::size_t i = 0; i < parts_.size(); ++i) {
    const auto& m = parts_[i].motion;
    if (m && t_end >= m->motion.start + m->motion.duration - 1e-12) clearPartMotion(i);
  }
}

void World::moveParts(const std::vector<Pose>& poses, const std::vector<bool>& displace) {
  // Parts that moved enough to change their envelope (below this the geometry is kept: a part the
  // powder holds does not redo it every step for numerical noise).
  constexpr double kMoved = 1e-7, kTurned = 1e-6;  // m, rad
  std::vector<std::size_t> moved;
  bool any_displaced = false;
  int i0 = powder_.nx(), i1 = -1, j0 = powder_.ny(), j1 = -1;  // cells the displacing parts cover, old or new
  auto extend = [&](const PartState& p) {
    if (p.fi0 > p.fi1) return;
    i0 = std::min(i0, p.fi0);
    i1 = std::max(i1, p.fi1);
    j0 = std::min(j0, p.fj0);
    j1 = std::max(j1, p.fj1);
  };
  for (std::size_t i = 0; i < parts_.size(); ++i) {
    PartState& p = parts_[i];
    p.spec.T_cell_part = poses[i];
    if (translationDistance(poses[i], p.T_geometry) <= kMoved &&
        rotationAngle(poses[i].linear(), p.T_geometry.linear()) <= kTurned)
      continue;
    moved.push_back(i);
    if (displace[i]) {
      any_displaced = true;
      extend(p);
    }
  }
  if (moved.empty()) return;

  // Part material below height h in column c: sum over parts of [bottom, top] cut at h.
  auto occupied = [&](std::size_t c, double h, const std::vector<const PartState*>& ps,
                      const std::vector<const std::vector<double>*>& tops,
                      const std::vector<const std::vector<double>*>& bottoms) {
    double occ = 0;
    for (std::size_t k = 0; k < ps.size(); ++k) {
      const double top = (*tops[k])[c], bottom = std::max(0.0, (*bottoms[k])[c]);  // none below the box floor
      if (std::isfinite(top) && h > bottom) occ += std::min(top, h) - bottom;
    }
    return occ;
  };
  std::vector<const PartState*> all;
  std::vector<const std::vector<double>*> tops, bottoms;
  for (const auto& p : parts_) {
    all.push_back(&p);
    tops.push_back(&p.top);
    bottoms.push_back(&p.bottom);
  }

  // 1. Before: each column's powder (surface height less the parts below it), over the window.
  std::vector<std::vector<double>> old_top(parts_.size()), old_bottom(parts_.size());
  std::vector<double> column;
  if (any_displaced) {
    for (std::size_t i : moved) {
      old_top[i] = parts_[i].top;
      old_bottom[i] = parts_[i].bottom;
    }
  }
  // 2. New envelopes and floors.
  for (std::size_t i : moved) updatePartGeometry(parts_[i]);
  if (!any_displaced) {
    updateFloor();
    return;
  }
  for (std::size_t i : moved)
    if (displace[i]) extend(parts_[i]);
  std::vector<const std::vector<double>*> tops_old = tops, bottoms_old = bottoms;
  for (std::size_t i : moved) {
    tops_old[i] = &old_top[i];
    bottoms_old[i] = &old_bottom[i];
  }
  const int w = i1 - i0 + 1;
  column.assign(static_cast<std::size_t>(std::max(0, w)) * std::max(0, j1 - j0 + 1), 0.0);
  for (int j = j0; j <= j1; ++j)
    for (int i = i0; i <= i1; ++i) {
      const std::size_t c = powder_.index(i, j);
      const double h = powder_.height(c);
      column[static_cast<std::size_t>(j - j0) * w + (i - i0)] =
          std::max(0.0, h - occupied(c, h, all, tops_old, bottoms_old));
    }
  updateFloor();
  // 3. After: the surface h' with h' - (parts below h') = the column's powder, never below the floor.
  std::vector<std::pair<double, double>> intervals;
  double gap = 0;  // m (per cell area) of gaps opened under parts
  for (int j = j0; j <= j1; ++j)
    for (int i = i0; i <= i1; ++i) {
      const std::size_t c = powder_.index(i, j);
      const double powder = column[static_cast<std::size_t>(j - j0) * w + (i - i0)];
      // Stack the column from the bottom up: a part whose bottom the powder reaches is lifted onto it whole.
      intervals.clear();
      for (const auto& p : parts_)
        if (std::isfinite(p.top[c])) intervals.emplace_back(std::max(0.0, p.bottom[c]), p.top[c]);
      std::sort(intervals.begin(), intervals.end());
      double h = powder;
      for (const auto& [bottom, top] : intervals)
        if (h > bottom) h += top - bottom;
      // A part whose bottom rose above its column's powder opened a gap under it: powder runs in from
      // around it (taken below), so the gap is filled and the column's surface is its top.
      if (!intervals.empty() && h <= intervals.front().first) gap += intervals.front().first - h;
      h = std::max(h, powder_.floor(c));
      if (std::abs(h - powder_.height(c)) > 1e-12) powder_.setHeight(c, h);
    }
  // 4. The powder that ran into gaps comes from the ring of cells around the footprints.
  if (gap <= 0) return;
  std::vector<std::size_t> ring;
  double available = 0;
  for (int j = std::max(0, j0 - 1); j <= std::min(powder_.ny() - 1, j1 + 1); ++j)
    for (int i = std::max(0, i0 - 1); i <= std::min(powder_.nx() - 1, i1 + 1); ++i) {
      const std::size_t c = powder_.index(i, j);
      if (powder_.overPart(c)) continue;
      bool edge = false;
      for (int b = std::max(0, j - 1); b <= std::min(powder_.ny() - 1, j + 1) && !edge; ++b)
        for (int a = std::max(0, i - 1); a <= std::min(powder_.nx() - 1, i + 1) && !edge; ++a)
          edge = powder_.overPart(powder_.index(a, b));
      if (!edge) continue;
      ring.push_back(c);
      available += powder_.height(c) - powder_.floor(c);
    }
  if (available <= 0) return;
  const double share = std::min(1.0, gap / available);
  for (std::size_t c : ring) powder_.setHeight(c, powder_.height(c) - share * (powder_.height(c) - powder_.floor(c)));
}

}  // namespace depowder::sim
