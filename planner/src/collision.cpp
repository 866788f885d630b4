#include "depowder/planner/collision.hpp"

#include <array>
#include <optional>
#include <stdexcept>

#include "fcl_util.hpp"

namespace depowder::planner {

std::shared_ptr<FclMesh> makeBvh(const Mesh& mesh) {
  std::vector<fcl::Vector3d> vertices(mesh.vertices.begin(), mesh.vertices.end());
  std::vector<fcl::Triangle> triangles;
  triangles.reserve(mesh.triangles.size());
  for (const auto& t : mesh.triangles) triangles.emplace_back(t[0], t[1], t[2]);
  auto bvh = std::make_shared<FclMesh>();
  bvh->beginModel(static_cast<int>(triangles.size()), static_cast<int>(vertices.size()));
  bvh->addSubModel(vertices, triangles);
  bvh->endModel();
  return prepared(bvh);
}

// ---------------------------------------------------------------------------------------------
// PartShape

PartShape::PartShape(std::string name, Mesh mesh)
    : name_(std::move(name)), mesh_(std::move(mesh)), impl_(std::make_unique<Impl>()) {
  if (mesh_.triangles.empty()) throw std::invalid_argument("part '" + name_ + "' has no triangles");
  impl_->bvh = makeBvh(mesh_);
  samples_ = sampleSurface(mesh_, 0.003, 7).points;
}

PartShape::~PartShape() = default;

// ---------------------------------------------------------------------------------------------
// CollisionWorld

namespace {

/// Nozzle body grown by m: a cylinder of radius r + m from m below the tip to m above the top.
std::shared_ptr<FclGeometry> nozzleShape(const NozzleConfig& nozzle, double m) {
  return prepared(std::make_shared<fcl::Cylinderd>(nozzle.radius + m, nozzle.length + 2 * m));
}

/// Pose of that cylinder (centred on its axis) for the nozzle at T_cell_nozzle; +z of the
/// nozzle points away from the body, so the body's centre is at -length/2.
Pose nozzleShapePose(const Pose& T_cell_nozzle, const NozzleConfig& nozzle) {
  Pose T_nozzle_shape = Pose::Identity();
  T_nozzle_shape.translation() = Point(0, 0, -0.5 * nozzle.length);
  return T_cell_nozzle * T_nozzle_shape;
}

/// A link capsule of the arm, or the end effector's cylinder: its pose in the link frame and
/// three grown copies.
struct ArmCapsule {
  int link = 0;
  std::string name;
  Pose T_link_shape = Pose::Identity();  // capsule axis along z, centred
  std::shared_ptr<FclGeometry> fixed, tracked, lost;
};

struct Static {
  std::string name;
  Placed object;
};

}  // namespace

struct CollisionWorld::Impl {
  std::vector<std::shared_ptr<const PartShape>> parts;
  std::vector<Placed> part_objects;
  std::vector<Pose> poses;
  std::vector<PartState> states;
  Box box;
  NozzleConfig nozzle;
  CollisionConfig config;
  std::vector<Static> statics;  // walls and floor
  std::optional<Placed> powder;
  double powder_top = 0;
  // The nozzle grown for static obstacles, tracked parts and lost parts.
  std::shared_ptr<FclGeometry> nozzle_static, nozzle_tracked, nozzle_lost;
  std::shared_ptr<const robot::ArmConfig> arm;
  std::vector<ArmCapsule> capsules;

  Contact armContact(const robot::Joints& q, const CheckOptions& o) const {
    if (!robot::withinLimits(*arm, q)) return {true, "joint limits"};
    const std::vector<Pose> links = robot::linkPoses(q);
    std::vector<Placed> fixed;
    fixed.reserve(capsules.size());
    for (const ArmCapsule& c : capsules) {
      const Pose T = arm->T_cell_base * links[c.link] * c.T_link_shape;
      fixed.push_back(place(c.fixed, T));
      for (const Static& s : statics)
        if (collide(fixed.back(), s.object)) return {true, c.name + "-" + s.name};
      if (o.powder && powder && collide(fixed.back(), *powder)) return {true, c.name + "-powder"};
      for (std::size_t i = 0; i < parts.size(); ++i) {
        if (states[i] == PartState::kIgnored || static_cast<int>(i) == o.ignore_part) continue;
        const bool lost = states[i] == PartState::kLost && o.lost_margin;
        const Placed grown = place(lost ? c.lost : c.tracked, T);
        if (collide(grown, part_objects[i])) return {true, c.name + "-part:" + parts[i]->name(), static_cast<int>(i)};
      }
    }
    const Pose T_cell_nozzle = arm->T_cell_base * links[6] * arm->T_flange_nozzle;
    if (Contact c = nozzleContact(T_cell_nozzle, o)) return c;
    // Self collision: the nozzle against the links up to the elbow (the wrist carries it).
    const Placed n = place(nozzle_static, nozzleShapePose(T_cell_nozzle, nozzle));
    for (std::size_t k = 0; k < capsules.size(); ++k)
      if (capsules[k].link <= 3 && collide(n, fixed[k])) return {true, "nozzle-" + capsules[k].name};
    return {};
  }

  Contact nozzleContact(const Pose& T_cell_nozzle, const CheckOptions& o) const {
    const Eigen::Vector3d tip = T_cell_nozzle.translation();
    if ((tip.array() < config.workspace_min.array()).any() || (tip.array() > config.workspace_max.array()).any())
      return {true, "workspace"};
    const Pose T = nozzleShapePose(T_cell_nozzle, nozzle);
    const Placed fixed = place(nozzle_static, T);
    for (const Static& s : statics)
      if (collide(fixed, s.object)) return {true, "nozzle-" + s.name};
    if (o.powder && powder && collide(fixed, *powder)) return {true, "nozzle-powder"};
    const Placed tracked = place(nozzle_tracked, T);
    const Placed lost = place(nozzle_lost, T);
    for (std::size_t i = 0; i < parts.size(); ++i) {
      if (states[i] == PartState::kIgnored || static_cast<int>(i) == o.ignore_part) continue;
      const Placed& n = states[i] == PartState::kLost && o.lost_margin ? lost : tracked;
      if (collide(n, part_objects[i])) return {true, "nozzle-part:" + parts[i]->name(), static_cast<int>(i)};
    }
    return {};
  }
};

CollisionWorld::CollisionWorld(std::vector<std::shared_ptr<const PartShape>> parts, const Box& box,
                               const NozzleConfig& nozzle, const CollisionConfig& config,
                               std::shared_ptr<const robot::ArmConfig> arm)
    : impl_(std::make_unique<Impl>()) {
  Impl& w = *impl_;
  w.arm = std::move(arm);
  NozzleConfig body = nozzle;
  if (w.arm) {
    // The nozzle body reaches at least up to the flange.
    body.length = std::max(nozzle.length, w.arm->T_flange_nozzle.translation().norm());
    for (const robot::LinkCapsule& c : robot::linkCapsules()) {
      const double len = (c.p1 - c.p0).norm();
      auto capsule = [&](double m) { return prepared(std::make_shared<fcl::Capsuled>(c.radius + m, len)); };
      w.capsules.push_back({c.link, c.name, segmentFrame(c.p0, c.p1), capsule(config.arm_margin),
                            capsule(config.arm_margin + config.tracking_margin),
                            capsule(config.arm_margin + config.lost_margin)});
    }
    // The end effector's body on the flange; the nozzle cylinder below covers the tube to the tip.
    for (const EffectorBody& e : effectorBodies(w.arm->effector, w.arm->T_flange_nozzle)) {
      auto cylinder = [&](double m) {
        return prepared(std::make_shared<fcl::Cylinderd>(e.radius + m, e.length + 2 * m));
      };
      w.capsules.push_back({6, "effector", e.T_flange_body, cylinder(config.arm_margin),
                            cylinder(config.arm_margin + config.tracking_margin),
                            cylinder(config.arm_margin + config.lost_margin)});
    }
  }
  w.parts = std::move(parts);
  w.box = box;
  w.nozzle = body;
  w.config = config;
  for (const auto& p : w.parts) {
    if (!p) throw std::invalid_argument("CollisionWorld: null part");
    w.part_objects.push_back(place(p->impl().bvh));
    w.poses.push_back(Pose::Identity());
    w.states.push_back(PartState::kIgnored);
  }
  // Walls from below the floor to the box's rim, and the floor, each `wall` thick.
  const Eigen::Vector3d s = box.size;
  const double t = box.wall;
  const double h = s.z() + t;
  const double zc = 0.5 * s.z() - 0.5 * t;
  auto add = [&](const std::string& name, const Eigen::Vector3d& size, const Eigen::Vector3d& centre) {
    Pose T = Pose::Identity();
    T.translation() = centre;
    w.statics.push_back({name, place(prepared(std::make_shared<fcl::Boxd>(size)), T)});
  };
  add("wall:+x", {t, s.y() + 2 * t, h}, {0.5 * (s.x() + t), 0, zc});
  add("wall:-x", {t, s.y() + 2 * t, h}, {-0.5 * (s.x() + t), 0, zc});
  add("wall:+y", {s.x() + 2 * t, t, h}, {0, 0.5 * (s.y() + t), zc});
  add("wall:-y", {s.x() + 2 * t, t, h}, {0, -0.5 * (s.y() + t), zc});
  add("floor", {s.x() + 2 * t, s.y() + 2 * t, t}, {0, 0, -0.5 * t});
  w.nozzle_static = nozzleShape(body, body.margin);
  w.nozzle_tracked = nozzleShape(body, body.margin + config.tracking_margin);
  w.nozzle_lost = nozzleShape(body, body.margin + config.lost_margin);
}

CollisionWorld::~CollisionWorld() = default;

std::size_t CollisionWorld::numParts() const { return impl_->parts.size(); }
const PartShape& CollisionWorld::part(std::size_t i) const { return *impl_->parts.at(i); }

void CollisionWorld::setPart(std::size_t i, const Pose& T_cell_part, PartState state) {
  Impl& w = *impl_;
  w.poses.at(i) = T_cell_part;
  w.states.at(i) = state;
  w.part_objects.at(i) = place(w.part_objects.at(i).geometry, T_cell_part);
}

const Pose& CollisionWorld::partPose(std::size_t i) const { return impl_->poses.at(i); }
PartState CollisionWorld::partState(std::size_t i) const { return impl_->states.at(i); }

void CollisionWorld::setPowderTop(double top) {
  Impl& w = *impl_;
  w.powder_top = top > 0 ? top : 0;
  if (top <= 0) {
    w.powder.reset();
    return;
  }
  Pose T = Pose::Identity();
  T.translation() = Point(0, 0, 0.5 * top);
  w.powder = place(prepared(std::make_shared<fcl::Boxd>(w.box.size.x(), w.box.size.y(), top)), T);
}

double CollisionWorld::powderTop() const { return impl_->powder_top; }

Contact CollisionWorld::checkNozzle(const Pose& T_cell_nozzle, const CheckOptions& options) const {
  return impl_->nozzleContact(T_cell_nozzle, options);
}

Contact CollisionWorld::checkArm(const robot::Joints& q, const CheckOptions& options) const {
  if (!impl_->arm) throw std::logic_error("CollisionWorld::checkArm: no arm model");
  return impl_->armContact(q, options);
}

const robot::ArmConfig& CollisionWorld::arm() const {
  if (!impl_->arm) throw std::logic_error("CollisionWorld::arm: no arm model");
  return *impl_->arm;
}

const Box& CollisionWorld::box() const { return impl_->box; }
const NozzleConfig& CollisionWorld::nozzle() const { return impl_->nozzle; }
const CollisionConfig& CollisionWorld::config() const { return impl_->config; }

}  // namespace depowder::planner
