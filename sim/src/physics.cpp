#include "depowder/sim/physics.hpp"

#include <btBulletDynamicsCommon.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <stdexcept>
#include <string>

#include "depowder/sim/world.hpp"

namespace depowder::sim {
namespace {

btVector3 toBt(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }
Eigen::Vector3d toEigen(const btVector3& v) { return {v.x(), v.y(), v.z()}; }

btTransform toBt(const Pose& T) {
  const Eigen::Matrix3d& R = T.linear();
  return btTransform(btMatrix3x3(R(0, 0), R(0, 1), R(0, 2), R(1, 0), R(1, 1), R(1, 2), R(2, 0), R(2, 1), R(2, 2)),
                     toBt(T.translation()));
}

Pose toEigen(const btTransform& T) {
  Pose out = Pose::Identity();
  const btMatrix3x3& R = T.getBasis();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) out.linear()(r, c) = R[r][c];
  out.translation() = toEigen(T.getOrigin());
  return out;
}

// Pose a + s (b - a): straight line, shortest rotation.
Pose interpolate(const Pose& a, const Pose& b, double s) {
  if (s >= 1) return b;
  Pose out = Pose::Identity();
  out.translation() = a.translation() + s * (b.translation() - a.translation());
  out.linear() = Eigen::Quaterniond(a.linear()).slerp(s, Eigen::Quaterniond(b.linear())).toRotationMatrix();
  return out;
}

// A kinematic body's pose for the coming substep (Bullet reads it and derives the velocity).
struct KinematicMotion : public btMotionState {
  btTransform T = btTransform::getIdentity();
  void getWorldTransform(btTransform& out) const override { out = T; }
  void setWorldTransform(const btTransform&) override {}
};

enum BodyKind { kStatic = 0, kPart = 1, kTool = 2 };

// A convex hull shape (points shrunk by the margin, so the surface stays where it is).
std::unique_ptr<btConvexHullShape> hullShape(const std::vector<Eigen::Vector3d>& points, double margin) {
  std::vector<Eigen::Vector3d> v = hullVertices(points, margin);
  if (v.size() < 4) v = hullVertices(points, 0);
  if (v.size() < 4) return nullptr;
  auto shape = std::make_unique<btConvexHullShape>();
  for (const auto& p : v) shape->addPoint(toBt(p), false);
  shape->recalcLocalAabb();
  shape->setMargin(margin);
  shape->initializePolyhedralFeatures();
  return shape;
}

}  // namespace

Pose motionPose(const Motion& motion, const Pose& T_start, const Eigen::Vector2d& centre, double t) {
  const double s = std::clamp(t - motion.start, 0.0, motion.duration);
  Pose T = T_start;
  if (motion.kind == Motion::Kind::kLinear) {
    T.translation() += motion.velocity * s;
    return T;
  }
  const Eigen::Vector3d c(centre.x(), centre.y(), 0);
  return Eigen::Translation3d(c) * Eigen::AngleAxisd(motion.rate * s, Eigen::Vector3d::UnitZ()) *
         Eigen::Translation3d(-c) * T_start;
}

struct Physics::Impl {
  PhysicsConfig config;
  btDefaultCollisionConfiguration collision_config;
  btCollisionDispatcher dispatcher{&collision_config};
  btDbvtBroadphase broadphase;
  btSequentialImpulseConstraintSolver solver;
  btDiscreteDynamicsWorld world{&dispatcher, &broadphase, &solver, &collision_config};

  struct Body {
    std::unique_ptr<btCollisionShape> shape;
    std::vector<std::unique_ptr<btCollisionShape>> children;
    std::unique_ptr<btRigidBody> body;
    KinematicMotion motion;
    bool in_world = false;
    Pose T_last = Pose::Identity();  ///< kinematic: pose at the end of the last step (body frame)
  };
  struct Part {
    Body b;
    MassProperties mass;
    btVector3 inertia_diag;
    Pose T_body_part = Pose::Identity();  ///< the part frame in the body (centre of mass, principal axes) frame
    std::vector<ConvexPiece> pieces;
    PowderSupport powder;
    bool scripted = false;
    bool touching = false;
  };
  std::vector<Body> statics;
  std::vector<Part> parts;
  Body nozzle;
  std::vector<Body> links;
  PhysicsStats stats;

  explicit Impl(const PhysicsConfig& c) : config(c) {
    world.setGravity(btVector3(0, 0, -c.gravity));
    world.getSolverInfo().m_numIterations = c.solver_iterations;
    world.getSolverInfo().m_splitImpulse = 1;
  }

  ~Impl() {
    for (auto* list : {&statics, &links})
      for (auto& b : *list) remove(b);
    for (auto& p : parts) remove(p.b);
    remove(nozzle);
  }

  void add(Body& b) {
    if (b.in_world || !b.body) return;
    world.addRigidBody(b.body.get());
    b.body->setActivationState(DISABLE_DEACTIVATION);
    b.in_world = true;
  }
  void remove(Body& b) {
    if (!b.in_world) return;
    world.removeRigidBody(b.body.get());
    b.in_world = false;
  }

  void addStaticBox(const Eigen::Vector3d& half, const Eigen::Vector3d& centre) {
    Body b;
    auto box = std::make_unique<btBoxShape>(toBt(half));
    box->initializePolyhedralFeatures();
    b.shape = std::move(box);
    btRigidBody::btRigidBodyConstructionInfo info(0, nullptr, b.shape.get());
    info.m_startWorldTransform.setOrigin(toBt(centre));
    info.m_friction = config.friction;
    info.m_restitution = config.restitution;
    b.body = std::make_unique<btRigidBody>(info);
    b.body->setUserIndex(-1);
    b.body->setUserIndex2(kStatic);
    statics.push_back(std::move(b));
    add(statics.back());
  }

  // A kinematic body from a mesh's convex hull (the nozzle, a link).
  void makeTool(Body& b, const Mesh& mesh) {
    const bool was = b.in_world;
    remove(b);
    b.body.reset();
    b.shape = hullShape(mesh.vertices, config.margin);
    if (!b.shape) return;
    btRigidBody::btRigidBodyConstructionInfo info(0, &b.motion, b.shape.get());
    info.m_friction = config.nozzle_friction;
    info.m_restitution = config.restitution;
    b.body = std::make_unique<btRigidBody>(info);
    b.body->setCollisionFlags(b.body->getCollisionFlags() | btCollisionObject::CF_KINEMATIC_OBJECT);
    b.body->setUserIndex(-1);
    b.body->setUserIndex2(kTool);
    if (was) add(b);
  }

  // Places a kinematic body at once (no velocity).
  static void place(Body& b, const Pose& T) {
    b.T_last = T;
    b.motion.T = toBt(T);
    if (!b.body) return;
    b.body->setWorldTransform(b.motion.T);
    b.body->setInterpolationWorldTransform(b.motion.T);
    b.body->setLinearVelocity(btVector3(0, 0, 0));
    b.body->setAngularVelocity(btVector3(0, 0, 0));
  }

  Pose partPose(const Part& p) const { return toEigen(p.b.body->getWorldTransform()) * p.T_body_part; }
};

Physics::Physics(const PhysicsConfig& config, const BoxGeometry& box, const std::vector<PartSpec>& parts,
                 const std::vector<const PartSolid*>& solids)
    : impl_(std::make_unique<Impl>(config)) {
  if (!(config.substep_hz > 0) || !(config.margin >= 0))
    throw std::invalid_argument("Physics: substep_hz must be positive and margin not negative");
  if (solids.size() != parts.size()) throw std::invalid_argument("Physics: one solid per part is needed");
  Impl& m = *impl_;
  // The box: floor and walls as thick static boxes (nothing tunnels through them), twice as high as the box.
  const double X = 0.5 * box.size.x(), Y = 0.5 * box.size.y(), H = box.size.z(), t = 0.05;
  m.addStaticBox({X + 2 * t, Y + 2 * t, t}, {0, 0, -t});
  m.addStaticBox({t, Y + 2 * t, H}, {-X - t, 0, H / 2});
  m.addStaticBox({t, Y + 2 * t, H}, {X + t, 0, H / 2});
  m.addStaticBox({X, t, H}, {0, -Y - t, H / 2});
  m.addStaticBox({X, t, H}, {0, Y + t, H / 2});

  for (std::size_t i = 0; i < parts.size(); ++i) {
    const PartSpec& spec = parts[i];
    m.parts.emplace_back();
    Impl::Part& p = m.parts.back();
    p.mass = sim::massProperties(*solids[i], spec.density, config.mass_voxel);
    if (!(p.mass.mass > 0)) throw std::invalid_argument("Physics: part '" + spec.name + "' has no volume");
    // Body frame: centre of mass, principal axes (right-handed).
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(p.mass.inertia);
    Eigen::Matrix3d R = eig.eigenvectors();
    if (R.determinant() < 0) R.col(2) *= -1;
    const Eigen::Vector3d I = eig.eigenvalues();
    p.inertia_diag = toBt(I);
    Pose T_part_body = Pose::Identity();
    T_part_body.linear() = R;
    T_part_body.translation() = p.mass.centre;
    p.T_body_part = T_part_body.inverse();
    // Collision shape: convex pieces of the filled solid, in the body frame.
    const FilledSolid filled(spec.mesh, *solids[i], 0.001);
    p.pieces = convexDecomposition(spec.mesh, filled, config.decomposition);
    auto compound = std::make_unique<btCompoundShape>();
    for (const ConvexPiece& piece : p.pieces) {
      std::vector<Eigen::Vector3d> pts(piece.points.size());
      for (std::size_t k = 0; k < pts.size(); ++k) pts[k] = p.T_body_part * piece.points[k];
      auto hull = hullShape(pts, config.margin);
      if (!hull) continue;
      compound->addChildShape(btTransform::getIdentity(), hull.get());
      p.b.children.push_back(std::move(hull));
    }
    if (p.b.children.empty()) throw std::invalid_argument("Physics: part '" + spec.name + "' has no convex piece");
    compound->setMargin(config.margin);
    m.stats.hulls += static_cast<int>(p.b.children.size());
    p.b.shape = std::move(compound);
    btRigidBody::btRigidBodyConstructionInfo info(p.mass.mass, nullptr, p.b.shape.get(), p.inertia_diag);
    info.m_startWorldTransform = toBt(spec.T_cell_part * T_part_body);
    info.m_friction = config.friction;
    info.m_restitution = config.restitution;
    p.b.body = std::make_unique<btRigidBody>(info);
    p.b.body->setUserIndex(static_cast<int>(i));
    p.b.body->setUserIndex2(kPart);
    p.powder = PowderSupport(config.powder, outerSurfaceSamples(spec.mesh, filled, config.powder.sample_spacing),
                             p.T_body_part, p.mass.mass, I, config.gravity);
    m.add(p.b);
  }
}

Physics::~Physics() = default;

void Physics::setNozzleMesh(const Mesh& mesh) {
  impl_->makeTool(impl_->nozzle, mesh);
  Impl::place(impl_->nozzle, impl_->nozzle.T_last);
}

void Physics::setArmLinks(const std::vector<Mesh>& link_meshes) {
  Impl& m = *impl_;
  for (auto& b : m.links) m.remove(b);
  m.links.clear();
  m.links.resize(link_meshes.size());
  for (std::size_t k = 0; k < link_meshes.size(); ++k) m.makeTool(m.links[k], link_meshes[k]);
}

void Physics::teleport(std::size_t part, const Pose& T_cell_part) {
  Impl::Part& p = impl_->parts.at(part);
  const Pose T_cell_body = T_cell_part * p.T_body_part.inverse();
  if (p.scripted) {
    Impl::place(p.b, T_cell_body);
  } else {
    const btTransform T = toBt(T_cell_body);
    p.b.body->setWorldTransform(T);
    p.b.body->setInterpolationWorldTransform(T);
    p.b.body->setLinearVelocity(btVector3(0, 0, 0));
    p.b.body->setAngularVelocity(btVector3(0, 0, 0));
    p.b.body->clearForces();
  }
  p.powder.reset();
}

void Physics::setScripted(std::size_t part, bool scripted) {
  Impl& m = *impl_;
  Impl::Part& p = m.parts.at(part);
  if (p.scripted == scripted) return;
  const btTransform T = p.b.body->getWorldTransform();
  m.remove(p.b);
  btRigidBody& body = *p.b.body;
  if (scripted) {
    body.setMassProps(0, btVector3(0, 0, 0));
    body.setCollisionFlags(body.getCollisionFlags() | btCollisionObject::CF_KINEMATIC_OBJECT);
    p.b.motion.T = T;
    body.setMotionState(&p.b.motion);
    p.b.T_last = toEigen(T);
  } else {
    body.setCollisionFlags(body.getCollisionFlags() & ~btCollisionObject::CF_KINEMATIC_OBJECT);
    body.setMotionState(nullptr);
    body.setMassProps(p.mass.mass, p.inertia_diag);
    body.setWorldTransform(T);
  }
  body.setInterpolationWorldTransform(T);
  body.setLinearVelocity(btVector3(0, 0, 0));
  body.setAngularVelocity(btVector3(0, 0, 0));
  body.updateInertiaTensor();
  p.powder.reset();
  p.scripted = scripted;
  m.add(p.b);
}

void Physics::step(double dt, const StepInput& in) {
  Impl& m = *impl_;
  if (!(dt > 0)) return;
  const int n = std::max(1, static_cast<int>(std::lround(dt * m.config.substep_hz)));
  const double h = dt / n;
  const btVector3 g = m.world.getGravity();

  // 1. Tools in or out of the cell; a tool entering appears at its pose (no sweep).
  if (in.nozzle_present && m.nozzle.body && !m.nozzle.in_world) {
    Impl::place(m.nozzle, in.T_cell_nozzle);
    m.add(m.nozzle);
  }
  if (!in.nozzle_present) m.remove(m.nozzle);
  const bool links_on = !in.T_cell_links.empty() && in.T_cell_links.size() == m.links.size();
  for (std::size_t k = 0; k < m.links.size(); ++k) {
    Impl::Body& b = m.links[k];
    if (links_on && b.body && !b.in_world) {
      Impl::place(b, in.T_cell_links[k]);
      m.add(b);
    }
    if (!links_on) m.remove(b);
  }

  // 2. The powder beside each free part, once per step.
  for (std::size_t i = 0; i < m.parts.size(); ++i) {
    Impl::Part& p = m.parts[i];
    p.touching = false;
    if (p.scripted || !in.powder) continue;
    auto covered = [&](std::size_t cell) { return in.covered ? in.covered(i, cell) : false; };
    powderLevels(p.powder.samples(), m.partPose(p), *in.powder, covered, in.repose_deg, p.powder.levels());
  }

  // 3. Substeps: kinematic poses, powder impulses, the engine's step, touches.
  std::vector<Pose> from(m.parts.size());
  for (std::size_t i = 0; i < m.parts.size(); ++i) from[i] = m.parts[i].b.T_last;
  for (int s = 1; s <= n; ++s) {
    const double a = static_cast<double>(s) / n;
    if (m.nozzle.in_world) m.nozzle.motion.T = toBt(interpolate(m.nozzle.T_last, in.T_cell_nozzle, a));
    for (std::size_t k = 0; k < m.links.size(); ++k)
      if (m.links[k].in_world) m.links[k].motion.T = toBt(interpolate(m.links[k].T_last, in.T_cell_links[k], a));
    for (std::size_t i = 0; i < m.parts.size(); ++i) {
      Impl::Part& p = m.parts[i];
      if (p.scripted) {
        if (i < in.targets.size() && in.targets[i])
          p.b.motion.T = toBt(interpolate(from[i], *in.targets[i] * p.T_body_part.inverse(), a));
        continue;
      }
      btRigidBody& body = *p.b.body;
      const PowderSupport::Result r =
          p.powder.solve(toEigen(body.getWorldTransform()), toEigen(body.getLinearVelocity()),
                         toEigen(body.getAngularVelocity()), toEigen(g) * h, h);
      body.setLinearVelocity(toBt(r.v));
      body.setAngularVelocity(toBt(r.w));
    }
    m.world.stepSimulation(h, 0, h);
    ++m.stats.substeps;
    for (int k = 0; k < m.dispatcher.getNumManifolds(); ++k) {
      const btPersistentManifold* mf = m.dispatcher.getManifoldByIndexInternal(k);
      const btCollisionObject *a0 = mf->getBody0(), *a1 = mf->getBody1();
      const btCollisionObject* part = a0->getUserIndex2() == kPart ? a0 : a1->getUserIndex2() == kPart ? a1 : nullptr;
      const btCollisionObject* other = part == a0 ? a1 : a0;
      if (!part || other->getUserIndex2() != kTool) continue;
      for (int c = 0; c < mf->getNumContacts(); ++c)
        if (mf->getContactPoint(c).getDistance() < m.config.contact_distance)
          m.parts[part->getUserIndex()].touching = true;
    }
  }

  // 4. Where the kinematic bodies ended.
  if (m.nozzle.in_world) m.nozzle.T_last = in.T_cell_nozzle;
  for (std::size_t k = 0; k < m.links.size(); ++k)
    if (m.links[k].in_world) m.links[k].T_last = in.T_cell_links[k];
  for (std::size_t i = 0; i < m.parts.size(); ++i)
    if (m.parts[i].scripted && i < in.targets.size() && in.targets[i])
      m.parts[i].b.T_last = *in.targets[i] * m.parts[i].T_body_part.inverse();
}

Pose Physics::pose(std::size_t part) const { return impl_->partPose(impl_->parts.at(part)); }

bool Physics::touching(std::size_t part) const { return impl_->parts.at(part).touching; }
const MassProperties& Physics::massProperties(std::size_t part) const { return impl_->parts.at(part).mass; }
const std::vector<ConvexPiece>& Physics::pieces(std::size_t part) const { return impl_->parts.at(part).pieces; }
const PhysicsStats& Physics::stats() const { return impl_->stats; }
const PhysicsConfig& Physics::config() const { return impl_->config; }

}  // namespace depowder::sim
